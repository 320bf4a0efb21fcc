//! The scene registry ([`crate::scenes::registry`]) seen from Python: the catalog from which
//! `lagrangian.scenes` builds its functions, construction by name from a mapping of named
//! arguments, drawing geometry and exact solutions.

use super::error::guard;
use super::model::AnyModel;
use super::py_model::PyModel;
use crate::scenes::registry::{self, Arguments, Coordinates, Kind, Value};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyList, PyString, PyTuple};
use std::sync::Arc;

/// A real number, refusing `bool` (which Python would take for 0 or 1).
fn real(scene: &str, name: &str, v: &Bound<'_, PyAny>) -> PyResult<f64> {
    let refuse = || {
        PyTypeError::new_err(format!(
            "{scene}: argument {name} must be a real number, got {}",
            v.repr().map(|r| r.to_string()).unwrap_or_default()
        ))
    };
    if v.is_instance_of::<PyBool>() {
        return Err(refuse());
    }
    v.extract::<f64>().map_err(|_| refuse())
}

/// The scene `name`'s arguments, checked by name (see [`Arguments::new`]).
pub(super) fn arguments(name: &str, given: &Bound<'_, PyDict>) -> PyResult<Arguments> {
    let info = registry::info(name)?;
    let mut pairs = Vec::with_capacity(given.len());
    for (k, v) in given.iter() {
        let key: String = k.extract()?;
        let number = v.is_instance_of::<PyBool>()
            || v.is_instance_of::<PyString>()
            || v.extract::<f64>().is_ok();
        // A list where a number is expected (or the other way round) reaches Arguments::new,
        // which names the mistake.
        let value = match v.try_iter() {
            Ok(items) if !number => {
                let mut xs = Vec::new();
                for x in items {
                    xs.push(real(name, &key, &x?)?);
                }
                Value::List(xs)
            }
            _ => Value::Number(real(name, &key, &v)?),
        };
        pairs.push((key, value));
    }
    Ok(Arguments::new(info, pairs)?)
}

fn value_object<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Number(x) => x.into_pyobject(py)?.into_any(),
        Value::List(xs) => PyList::new(py, xs)?.into_any(),
    })
}

/// Every scene as a dict: `name`, `doc`, `parameters` (a list of `(name, kind, default,
/// doc)`, kind `"number"` or `"list"`, default `None` when there is none), `coordinates`
/// (a list of names, or `(prefix, list parameter)` for numbered coordinates), `route`
/// (`"energy"` or `"particle"`) and `exact` (whether `scene_exact` answers).
#[pyfunction]
pub(crate) fn scene_catalog(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let out = PyList::empty(py);
    for s in registry::catalog() {
        let d = PyDict::new(py);
        d.set_item("name", s.name)?;
        d.set_item("doc", s.doc)?;
        let params = PyList::empty(py);
        for p in s.parameters {
            let (kind, default) = match p.kind {
                Kind::Number(x) => ("number", x.map(Value::Number)),
                Kind::List(xs) => ("list", xs.map(|xs| Value::List(xs.to_vec()))),
            };
            let default = match default {
                Some(v) => value_object(py, &v)?,
                None => py.None().into_bound(py),
            };
            params.append(PyTuple::new(
                py,
                [
                    p.name.into_pyobject(py)?.into_any(),
                    kind.into_pyobject(py)?.into_any(),
                    default,
                    p.doc.into_pyobject(py)?.into_any(),
                ],
            )?)?;
        }
        d.set_item("parameters", params)?;
        match s.coordinates {
            Coordinates::Fixed(names) => d.set_item("coordinates", names.to_vec())?,
            Coordinates::Numbered { prefix, per } => d.set_item("coordinates", (prefix, per))?,
        }
        d.set_item("route", s.route.name())?;
        d.set_item("exact", s.exact)?;
        out.append(d)?;
    }
    Ok(out)
}

/// The scene `name` built from a mapping of named arguments (defaults for the rest): the
/// native model, the full parameter values (a dict in the scene's order) and the coordinate
/// names.
#[pyfunction]
pub(crate) fn scene_model<'py>(
    py: Python<'py>,
    name: &str,
    arguments: &Bound<'py, PyDict>,
) -> PyResult<(PyModel, Bound<'py, PyDict>, Vec<String>)> {
    guard(|| {
        let args = self::arguments(name, arguments)?;
        let model = AnyModel::scene(&args)?;
        let values = PyDict::new(py);
        for (p, v) in args.info().parameters.iter().zip(args.values()) {
            values.set_item(p.name, value_object(py, v)?)?;
        }
        let names = args.info().coordinate_names(&args);
        Ok((
            PyModel {
                model: Arc::new(model),
                compiled: None,
            },
            values,
            names,
        ))
    })
}

/// How to draw the scene: a dict with `rods`, `moving_pivot`, `bodies`, `circles`, `lines`,
/// `marks` and `trail` (`None` for the default), or `None` for points with trails.
#[pyfunction]
pub(crate) fn scene_drawing<'py>(
    py: Python<'py>,
    name: &str,
    arguments: &Bound<'py, PyDict>,
) -> PyResult<Option<Bound<'py, PyDict>>> {
    guard(|| {
        let Some(d) = registry::drawing(&self::arguments(name, arguments)?) else {
            return Ok(None);
        };
        let out = PyDict::new(py);
        out.set_item("rods", d.rods)?;
        out.set_item("moving_pivot", d.moving_pivot)?;
        out.set_item("bodies", d.bodies)?;
        out.set_item("circles", d.circles)?;
        out.set_item("lines", d.lines)?;
        out.set_item("marks", d.marks)?;
        out.set_item("trail", d.trail)?;
        Ok(Some(out))
    })
}

/// The scene's pivot at the times `t`: shape (len(t), 2).
#[pyfunction]
pub(crate) fn scene_pivot<'py>(
    py: Python<'py>,
    name: &str,
    arguments: &Bound<'py, PyDict>,
    t: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(|| {
        let args = self::arguments(name, arguments)?;
        let t = t.as_array().iter().copied().collect::<Vec<f64>>();
        let p = registry::pivot(&args, &t);
        Ok(Array2::from_shape_fn((p.len(), 2), |(i, j)| p[i][j]).into_pyarray(py))
    })
}

/// (q, q̇) as two NumPy arrays.
type StatePair<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>);

/// The exact state (q, q̇) at time `t` from (`q0`, `qd0`) at t = 0, for a scene whose catalog
/// entry says `exact`; `ValueError` otherwise.
#[pyfunction]
pub(crate) fn scene_exact<'py>(
    py: Python<'py>,
    name: &str,
    arguments: &Bound<'py, PyDict>,
    q0: Vec<f64>,
    qd0: Vec<f64>,
    t: f64,
) -> PyResult<StatePair<'py>> {
    guard(|| {
        let args = self::arguments(name, arguments)?;
        let (q, qd) = registry::exact(&args, &q0, &qd0, t)?;
        Ok((PyArray1::from_vec(py, q), PyArray1::from_vec(py, qd)))
    })
}
