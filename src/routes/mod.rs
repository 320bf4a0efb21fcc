//! The routes from a model to its equations of motion, each a [`Dynamics`](crate::Dynamics):
//! [`System`] composed of its energies, [`ParticleSystem`] from particle positions,
//! [`EnergyModel`] from an energy stated at run time as a graph, and [`TapeParticles`], the
//! particle map of a run-time model, [`ExprConstraints`], constraints stated at run time, and
//! [`BodySystem`] from the poses of rigid bodies.

mod bodies;
mod energy_model;
mod expr_constraints;
mod particles;
mod system;
mod tape_particles;

pub use bodies::{BodyEnergyRoute, BodyGravity, BodyKinetic, BodySystem, RigidBodies};
pub use energy_model::{EnergyModel, TapeSystem};
pub use expr_constraints::ExprConstraints;
pub use particles::{
    CartesianForces, EnergyRoute, MappedForces, ParticleGravity, ParticleKinetic, ParticleSystem,
    Particles,
};
pub use system::System;
pub use tape_particles::TapeParticles;
