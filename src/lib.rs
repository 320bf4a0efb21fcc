//! # lagrangian
//!
//! Equations of motion from energies. State a mechanical system the way Lagrange does — kinetic
//! energy T, potential U, Rayleigh dissipation Φ, generalized forces Q″ — as Rust code generic
//! over a [`Scalar`]; the crate derives
//!
//! M q̈ = Q″ + ∂L/∂q − (∂²L/∂q̇∂q) q̇ − ∂²L/∂q̇∂t − ∂Φ/∂q̇,   L = T − U,  M = ∂²T/∂q̇²
//!
//! (eq. 55 of the seed document) by forward-mode dual numbers, and finds static equilibria by
//! the principle of virtual work.
//!
//! ```
//! use lagrangian::{Dynamics, KineticEnergy, Potential, Scalar, System};
//! # use approx::assert_relative_eq;
//! /// A simple pendulum of length l in gravity g: T = ½ m l² θ̇², U = −m g l cos θ.
//! struct Kinetic { m: f64, l: f64 }
//! impl KineticEnergy for Kinetic {
//!     fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
//!         qd[0] * qd[0] * (0.5 * self.m * self.l * self.l)
//!     }
//! }
//! struct Gravity { m: f64, g: f64, l: f64 }
//! impl Potential for Gravity {
//!     fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
//!         -q[0].cos() * (self.m * self.g * self.l)
//!     }
//! }
//! let pendulum = System::new(1, Kinetic { m: 1.0, l: 2.0 })
//!     .with_potential(Gravity { m: 1.0, g: 9.81, l: 2.0 });
//! let qdd = pendulum.accelerations(0.0, &[0.3], &[0.0]).unwrap();
//! assert_relative_eq!(qdd[0], -9.81 / 2.0 * 0.3_f64.sin(), epsilon = 1e-14);
//! ```

mod checks;
mod constrained;
mod derived;
mod dynamics;
mod energies;
mod eom;
mod error;
mod expr;
pub mod integrators;
mod linalg;
#[cfg(feature = "jit")]
mod native;
mod nonlinear;
mod program;
#[cfg(feature = "python")]
mod python;
pub mod rigid;
mod routes;
mod scalar;
pub mod scenes;
pub mod sensitivity;
mod statics;
pub mod tape;
mod taylor;
#[cfg(test)]
mod tests;
pub mod trace;

pub use constrained::{
    Constrained, ConstrainedAccelerations, ConstraintResiduals, PROJECTION_TOLERANCE,
};
pub use dynamics::{ConstraintAccess, DerivedProgram, Dynamics, Structure};
pub use energies::{Constraints, Dissipation, GeneralizedForces, KineticEnergy, Potential};
pub use error::{Error, Result};
pub use integrators::solve_with_interrupt;
pub use integrators::{Method, Options, Output, Solution, Statistics, solve};
/// The Python extension module `lagrangian._lagrangian`, for the `extension/` crate that links it.
#[cfg(feature = "python")]
#[doc(hidden)]
pub use python::lagrangian_module as python_module;
pub use routes::{
    BodyEnergyRoute, BodyGravity, BodyKinetic, BodySystem, CartesianForces, EnergyRoute,
    MappedForces, ParticleGravity, ParticleKinetic, ParticleSystem, Particles, RigidBodies, System,
};
pub use scalar::{Scalar, re};
pub use statics::{
    ConstrainedEquilibrium, Equilibrium, Linearization, ModeProblem, Modes, Stability,
    StaticsOptions, constrained_equilibrium, constrained_modes, equilibrium, linearize, modes,
    static_stiffness,
};

/// The dual-number library the crate differentiates with, re-exported for model code.
pub use num_dual;

/// The README's code, compiled and run as a doc test.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

/// The Rust examples the documentation site shows, run as doc tests so that their assertions
/// keep holding (`cargo test --doc`).
#[doc = concat!("```\n", include_str!("../examples/auto_fixed_step.rs"), "\n```")]
#[cfg(doctest)]
pub struct AutoFixedStepExample;

/// See [`AutoFixedStepExample`].
#[doc = concat!("```\n", include_str!("../examples/two_mass_modes.rs"), "\n```")]
#[cfg(doctest)]
pub struct TwoMassModesExample;

/// See [`AutoFixedStepExample`].
#[doc = concat!("```\n", include_str!("../examples/constrained_pendulum.rs"), "\n```")]
#[cfg(doctest)]
pub struct ConstrainedPendulumExample;
