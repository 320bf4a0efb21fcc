//! A pendulum whose pivot is driven vertically (Kapitza's pendulum when the drive is fast): the
//! reference problem for explicitly time-dependent kinetic energy.

use super::registry::{Arguments, Coordinates, Drawing, Parameter, Route, Scene, SceneInfo};
use crate::energies::{KineticEnergy, Potential};
use crate::error::Result;
use crate::routes::{ParticleSystem, Particles, System};
use crate::scalar::Scalar;

/// A point mass m on a massless rod of length l whose pivot moves as y_p(t) = a cos ω t, in
/// gravity g along −y; coordinate θ from the downward vertical, the bob at
/// (l sin θ, a cos ω t − l cos θ).
///
/// T = ½ m [(l cos θ θ̇)² + (l sin θ θ̇ − a ω sin ω t)²] — the pivot velocity stays in T, which
/// therefore depends on t and θ (a moving constraint, seed eq. 1/38) —
/// U = m g (a cos ω t − l cos θ), Φ = 0, Q″ = 0. M = m l² is still constant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrivenPendulum {
    /// Bob mass.
    pub m: f64,
    /// Rod length.
    pub l: f64,
    /// Gravitational acceleration.
    pub g: f64,
    /// Pivot amplitude a.
    pub a: f64,
    /// Pivot angular frequency ω.
    pub omega: f64,
}

impl DrivenPendulum {
    /// A pendulum of mass `m` and length `l` in gravity `g`, pivot y_p = `a` cos(`omega` t).
    pub fn new(m: f64, l: f64, g: f64, a: f64, omega: f64) -> Self {
        Self { m, l, g, a, omega }
    }

    /// The energy-route system.
    pub fn system(self) -> System<Self, Self> {
        System::new(1, self).with_potential(self)
    }

    /// The particle-route system: the bob at its time-dependent position, in gravity.
    pub fn particles(self) -> ParticleSystem<Self> {
        ParticleSystem::new(self).with_gravity([0.0, -self.g, 0.0])
    }

    /// Whether the pivot moves at all (a ≠ 0 and ω ≠ 0): only then do T, U and the positions
    /// depend on t.
    pub fn drives(&self) -> bool {
        self.a != 0.0 && self.omega != 0.0
    }

    /// The pivot height y_p(t) = a cos ω t.
    pub fn pivot(&self, t: f64) -> f64 {
        self.a * (self.omega * t).cos()
    }

    /// Closed form: θ̈ = −(g + ÿ_p)/l · sin θ = −(g − a ω² cos ω t)/l · sin θ.
    pub fn closed_form_accelerations(&self, t: f64, q: &[f64], _qd: &[f64]) -> [f64; 1] {
        let pivot_acc = -self.a * self.omega * self.omega * (self.omega * t).cos();
        [-(self.g + pivot_acc) / self.l * q[0].sin()]
    }
}

impl KineticEnergy for DrivenPendulum {
    const FIXED_DOF: Option<usize> = Some(1);
    fn kinetic<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        let (s, c) = q[0].sin_cos();
        let vx = c * qd[0] * self.l;
        let vy = s * qd[0] * self.l - (t * self.omega).sin() * (self.a * self.omega);
        (vx * vx + vy * vy) * (0.5 * self.m)
    }
    fn depends_on_time(&self) -> bool {
        self.drives()
    }
    fn constant_mass_matrix(&self) -> bool {
        true
    }
}

impl Potential for DrivenPendulum {
    fn potential<D: Scalar>(&self, t: D, q: &[D]) -> D {
        ((t * self.omega).cos() * self.a - q[0].cos() * self.l) * (self.m * self.g)
    }
    fn depends_on_time(&self) -> bool {
        self.drives()
    }
}

impl Particles for DrivenPendulum {
    const FIXED_DOF: Option<usize> = Some(1);
    fn dof(&self) -> usize {
        1
    }
    fn dim(&self) -> usize {
        2
    }
    fn count(&self) -> usize {
        1
    }
    fn mass(&self, _j: usize) -> f64 {
        self.m
    }
    fn positions<D: Scalar>(&self, t: D, q: &[D], r: &mut [D]) {
        let (s, c) = q[0].sin_cos();
        r[0] = s * self.l;
        r[1] = (t * self.omega).cos() * self.a - c * self.l;
    }
    fn depends_on_time(&self) -> bool {
        self.drives()
    }
}

impl Scene for DrivenPendulum {
    type System = System<Self, Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "driven_pendulum",
        doc: "A pendulum whose pivot moves as a cos ω t (T depends on t); coordinate ``theta``.",
        parameters: &[
            Parameter::number("m", 1.0, "bob mass"),
            Parameter::number("l", 1.0, "rod length"),
            Parameter::number("g", 9.81, "gravitational acceleration"),
            Parameter::number("a", 0.1, "pivot amplitude"),
            Parameter::number("omega", 20.0, "pivot angular frequency ω"),
        ],
        coordinates: Coordinates::Fixed(&["theta"]),
        route: Route::Energy,
        exact: false,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        Ok(Self::of(a).system())
    }
    fn drawing(_: &Arguments) -> Option<Drawing> {
        Some(Drawing::chain(1, true))
    }
    fn pivot(a: &Arguments, t: f64) -> [f64; 2] {
        [0.0, Self::of(a).pivot(t)]
    }
}

impl DrivenPendulum {
    fn of(a: &Arguments) -> Self {
        let n = |k| a.number(k);
        Self::new(n("m"), n("l"), n("g"), n("a"), n("omega"))
    }
}
