//! The Python extension module `lagrangian._lagrangian`, built by maturin (`pyproject.toml`).
//!
//! The binding itself is the `python` feature of the `lagrangian` crate (`src/python/`); this
//! crate only links it into the shared library Python imports, whose `PyInit__lagrangian` the
//! `#[pymodule]` there defines.

pub use lagrangian::python_module;
