//! The Python extension module `lagrangian._lagrangian` (cargo feature `python`, built by maturin).
//!
//! The user's energies are compiled once to a [`crate::tape`] and evaluated over the same dual
//! numbers as a Rust model, so no Python runs while a model is integrated. This file only
//! declares the files and the module; they are layered one way, each naming only those above
//! it in this list:
//!
//! - [`args`]: Python's arguments checked and converted (vectors, counts, a run's options),
//!   validated by [`crate::integrators::Options`] itself; [`interrupt`]: Ctrl-C polled during
//!   a run with the GIL released; [`states`]: the fast form of states read from Python;
//! - [`model`]: the models themselves (compiled from Python's expressions, or scenes);
//!   [`events`], [`solution`] and [`error`] (the exception classes, and `guard`: a panic
//!   caught and reported as `LagrangianError`); [`first_order`] (`rhs`, `jacobian` for
//!   SciPy) and [`linear`] (linearization, modes);
//! - [`integrator`]: the kept-state `Integrator`, built on the inner model;
//! - [`py_model`]: the compiled model ([`py_model::PyModel`], `NativeModel` in Python) and its methods;
//! - [`scenes`] (which builds a `PyModel`), [`ensemble`] (`simulate_many` on a `PyModel`) and
//!   [`methods`] (the method registry).
//!
//! The expression language, argument checking and docstrings of the public API live in
//! `python/lagrangian/`. Every entry point releases nothing half-done: inputs are checked
//! before any work, a failure is a typed exception, a panic is caught, and `simulate` releases
//! the GIL while it runs and polls for Ctrl-C (`KeyboardInterrupt`) every 20 ms.

mod args;
mod ensemble;
mod error;
mod events;
mod first_order;
mod integrator;
mod interrupt;
mod linear;
mod methods;
mod model;
mod py_model;
mod scenes;
mod sensitivity;
mod solution;
mod states;

/// The compiled core of the `lagrangian` package.
#[pyo3::pymodule(name = "_lagrangian")]
pub mod lagrangian_module {
    #[pymodule_export]
    use super::ensemble::simulate_many;
    #[pymodule_export]
    use super::error::{
        ConvergenceError, LagrangianError, NonFiniteError, SingularMassMatrixError, StepSizeError,
        StiffnessError, TooManyStepsError,
    };
    #[pymodule_export]
    use super::events::PyDense;
    #[pymodule_export]
    use super::integrator::PyIntegrator;
    #[pymodule_export]
    use super::methods::{check_options, method_info, methods};
    #[pymodule_export]
    use super::py_model::PyModel;
    #[pymodule_export]
    use super::scenes::{scene_catalog, scene_drawing, scene_exact, scene_model, scene_pivot};
    #[pymodule_export]
    use super::solution::PySolution;
    use pyo3::prelude::*;

    #[pymodule_init]
    fn init(m: &Bound<'_, PyModule>) -> PyResult<()> {
        let base = m.py().get_type::<super::error::LagrangianError>();
        for name in super::error::PARTIAL_ATTRIBUTES {
            base.setattr(name, m.py().None())?;
        }
        // The statistics' counter names, in the order of an ensemble's counter columns.
        let counters = crate::integrators::Statistics::COUNTERS.map(|(name, _)| name);
        m.add("COUNTERS", pyo3::types::PyTuple::new(m.py(), counters)?)?;
        m.add("__version__", env!("CARGO_PKG_VERSION"))
    }
}
