//! The Hénon–Heiles system: a separable two-degree-of-freedom Hamiltonian with regular and
//! chaotic orbits, the standard test of long-time symplectic integration.

use super::registry::{Arguments, Coordinates, Route, Scene, SceneInfo};
use crate::energies::{KineticEnergy, Potential};
use crate::error::Result;
use crate::routes::{ParticleSystem, Particles, System};
use crate::scalar::Scalar;

/// A unit mass in the plane, coordinates (x, y).
///
/// T = ½ (ẋ² + ẏ²), U = ½ (x² + y²) + x² y − y³/3, Φ = 0, Q″ = 0 (Hénon & Heiles 1964). Orbits
/// stay bounded below the escape energy 1/6.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HenonHeiles;

impl HenonHeiles {
    /// The escape energy: the potential's saddle points sit at U = 1/6.
    pub const ESCAPE_ENERGY: f64 = 1.0 / 6.0;

    /// The Hénon–Heiles system (it has no parameters).
    pub fn new() -> Self {
        Self
    }

    /// The energy-route system.
    pub fn system(self) -> System<Self, Self> {
        System::new(2, self).with_potential(self)
    }

    /// The particle-route system: one unit mass at (x, y) in the potential U.
    pub fn particles(self) -> ParticleSystem<Self, Self> {
        ParticleSystem::new(self).with_potential(self)
    }

    /// Closed form: ẍ = −x − 2 x y, ÿ = −y − x² + y².
    pub fn closed_form_accelerations(&self, q: &[f64], _qd: &[f64]) -> [f64; 2] {
        let (x, y) = (q[0], q[1]);
        [-x - 2.0 * x * y, -y - x * x + y * y]
    }
}

impl KineticEnergy for HenonHeiles {
    const FIXED_DOF: Option<usize> = Some(2);
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        (qd[0] * qd[0] + qd[1] * qd[1]) * 0.5
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn depends_on_position(&self) -> bool {
        false
    }
    fn constant_mass_matrix(&self) -> bool {
        true
    }
}

impl Potential for HenonHeiles {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let (x, y) = (q[0], q[1]);
        (x * x + y * y) * 0.5 + x * x * y - y * y * y * (1.0 / 3.0)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Particles for HenonHeiles {
    const FIXED_DOF: Option<usize> = Some(2);
    fn dof(&self) -> usize {
        2
    }
    fn dim(&self) -> usize {
        2
    }
    fn count(&self) -> usize {
        1
    }
    fn mass(&self, _j: usize) -> f64 {
        1.0
    }
    fn positions<D: Scalar>(&self, _t: D, q: &[D], r: &mut [D]) {
        r[0] = q[0];
        r[1] = q[1];
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Scene for HenonHeiles {
    type System = System<Self, Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "henon_heiles",
        doc: "The Hénon–Heiles system; coordinates ``x``, ``y``.",
        parameters: &[],
        coordinates: Coordinates::Fixed(&["x", "y"]),
        route: Route::Energy,
        exact: false,
    };
    fn build(_: &Arguments) -> Result<Self::System> {
        Ok(Self::new().system())
    }
}
