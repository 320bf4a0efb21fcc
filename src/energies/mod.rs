//! The energies a user implements to state a system (seed eq. 1, 3, 4, 54): kinetic energy T,
//! potential U, Rayleigh dissipation Φ and generalized forces Q″, each generic over a
//! [`Scalar`](crate::Scalar) so that every route differentiates them with dual numbers. `()` is the
//! absent part of each. [`Constraints`] states what restricts the motion (holonomic and velocity
//! constraints), for [`Constrained`](crate::Constrained).

mod constraints;
mod dissipation;
mod forces;
mod kinetic;
mod potential;

pub use constraints::Constraints;
pub use dissipation::Dissipation;
pub use forces::GeneralizedForces;
pub use kinetic::KineticEnergy;
pub use potential::Potential;
