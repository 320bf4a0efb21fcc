//! Ready-made, parametrised systems: every system of the seed document and the usual reference
//! problems. Each scene is a plain struct of parameters that implements the energy traits, with
//! a `system()` constructor (and `particles()` where the particle route applies) and, for tests
//! and benches, its hand-derived closed-form accelerations. Each also implements
//! [`registry::Scene`], its one declaration for the catalog and the Python binding.
//!
//! Every scene's energies trace into the expression graph ([`crate::trace`]): none branches on
//! the state's values or calls a function the graph lacks, so the Taylor method runs on every
//! scene (`tests/integration/trace.rs` checks each traced program against the Rust code). A new
//! scene must keep to that, or its Taylor runs fail with [`crate::Error::NotTraceable`] naming
//! the operation. [`Andrews`] (the squeezing mechanism) is a constrained system outside the
//! registry, which builds unconstrained ones.

mod andrews;
mod ball_in_sphere;
mod charged_particle;
mod damped_oscillator;
mod driven_pendulum;
mod elastic_pendulum;
mod forced_two_mass;
mod henon_heiles;
mod kepler;
mod pendulum;
pub mod registry;
mod rigid_disc;
mod rolling_cylinder;
mod spatial_chain;
mod virtual_work;

pub use andrews::{ANDREWS_COORDINATES, Andrews, AndrewsReference};
pub use ball_in_sphere::{BallInSphere, elliptic_k};
pub use charged_particle::{ChargedParticle, LorentzForce};
pub use damped_oscillator::DampedOscillator;
pub use driven_pendulum::DrivenPendulum;
pub use elastic_pendulum::{ElasticPendulum, RadialDamping, RadialSpring};
pub use forced_two_mass::ForcedTwoMass;
pub use henon_heiles::HenonHeiles;
pub use kepler::Kepler;
pub use pendulum::{DoublePendulum, NPendulum, SimplePendulum};
pub use registry::{Arguments, Drawing, Scene, SceneInfo, catalog};
pub use rolling_cylinder::RollingCylinder;
pub use spatial_chain::SpatialChain;
pub use virtual_work::{DifferentialPulley, Lever, RhombusLink, SpringRhombus, TwoSprings};
