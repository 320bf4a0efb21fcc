//! The integration tests, one module per concept, in one test binary.
//!
//! Every test binary links the whole crate and its dependencies, so one binary instead of one per
//! file saves a link (and its debug info) per file: `cargo test` builds and links this once.
//!
//! **A new integration test file goes here**: put it in `tests/integration/` and add its `mod`
//! line below (behind `#[cfg(feature = "...")]` if it needs a feature); shared helpers are in
//! `common.rs` (`use crate::common::...`). A file left in `tests/` itself would still run, but as
//! a binary of its own. Run one module with `cargo test --test integration NAME::`
//! (e.g. `cargo test --features jit --test integration events::`).

mod ad;
mod andrews;
mod bodies;
mod cartesian_chain;
mod common;
mod compiled;
mod constrained_motion;
mod constrained_statics;
mod constraint_tolerance;
mod constraints;
mod energy_model;
#[cfg(feature = "parallel")]
mod ensemble;
mod events;
mod fast_path;
mod graph_derivatives;
mod implicit;
mod integrator_refusals;
mod integrators;
mod linearize;
mod partial;
mod rattle;
mod routes;
mod scenes;
mod sensitivity;
mod statics;
mod step_limit;
mod tape_speed;
mod taylor;
mod taylor_series;
mod trace;
