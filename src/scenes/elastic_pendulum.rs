//! The spring (elastic) pendulum in polar coordinates, optionally with a radial dashpot.

use super::registry::{Arguments, Coordinates, Drawing, Parameter, Route, Scene, SceneInfo};
use crate::energies::{Dissipation, KineticEnergy, Potential};
use crate::error::Result;
use crate::routes::{ParticleSystem, Particles, System};
use crate::scalar::Scalar;

/// A mass m on a spring of stiffness k and natural length l₀, swinging in gravity g along −y;
/// coordinates (r, θ), θ from the downward vertical, the bob at (r sin θ, −r cos θ).
///
/// T = ½ m (ṙ² + r² θ̇²), U = ½ k (r − l₀)² − m g r cos θ, Q″ = 0, and Φ = 0 for
/// [`system`](Self::system) or Φ = ½ c ṙ² ([`RadialDamping`], seed eq. 54) for
/// [`damped`](Self::damped). T depends on r, so M = diag(m, m r²) is not constant and the system
/// is not separable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElasticPendulum {
    /// Bob mass.
    pub m: f64,
    /// Spring constant.
    pub k: f64,
    /// Natural length of the spring.
    pub l0: f64,
    /// Gravitational acceleration.
    pub g: f64,
}

impl ElasticPendulum {
    /// A spring pendulum of mass `m`, stiffness `k` and natural length `l0` in gravity `g`.
    pub fn new(m: f64, k: f64, l0: f64, g: f64) -> Self {
        Self { m, k, l0, g }
    }

    /// The undamped energy-route system (no dissipation part at all).
    pub fn system(self) -> System<Self, Self> {
        System::new(2, self).with_potential(self)
    }

    /// The energy-route system with the radial dashpot Φ = ½ c ṙ².
    pub fn damped(self, c: f64) -> System<Self, Self, RadialDamping> {
        self.system().with_dissipation(RadialDamping { c })
    }

    /// The particle-route system: one bob in gravity, the spring as a potential in r.
    /// Add damping with `.with_dissipation(RadialDamping { c })`.
    pub fn particles(self) -> ParticleSystem<Self, RadialSpring> {
        ParticleSystem::new(self)
            .with_gravity([0.0, -self.g, 0.0])
            .with_potential(RadialSpring {
                k: self.k,
                l0: self.l0,
            })
    }

    /// Closed form without damping; see
    /// [`closed_form_damped_accelerations`](Self::closed_form_damped_accelerations).
    pub fn closed_form_accelerations(&self, q: &[f64], qd: &[f64]) -> [f64; 2] {
        self.closed_form_damped_accelerations(0.0, q, qd)
    }

    /// Closed form with radial damping c:
    /// r̈ = r θ̇² − (k/m)(r − l₀) + g cos θ − (c/m) ṙ,  θ̈ = −(2 ṙ θ̇ + g sin θ) / r.
    pub fn closed_form_damped_accelerations(&self, c: f64, q: &[f64], qd: &[f64]) -> [f64; 2] {
        let Self { m, k, l0, g } = *self;
        let (r, th) = (q[0], q[1]);
        let (rd, thd) = (qd[0], qd[1]);
        let (s, co) = th.sin_cos();
        [
            r * thd * thd - k / m * (r - l0) + g * co - c / m * rd,
            -(2.0 * rd * thd + g * s) / r,
        ]
    }
}

impl KineticEnergy for ElasticPendulum {
    const FIXED_DOF: Option<usize> = Some(2);
    fn kinetic<D: Scalar>(&self, _t: D, q: &[D], qd: &[D]) -> D {
        let r = q[0];
        (qd[0] * qd[0] + r * r * qd[1] * qd[1]) * (0.5 * self.m)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Potential for ElasticPendulum {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let stretch = q[0] - self.l0;
        stretch * stretch * (0.5 * self.k) - q[0] * q[1].cos() * (self.m * self.g)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Particles for ElasticPendulum {
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
        self.m
    }
    fn positions<D: Scalar>(&self, _t: D, q: &[D], r: &mut [D]) {
        let (s, c) = q[1].sin_cos();
        r[0] = q[0] * s;
        r[1] = -q[0] * c;
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// The spring's own energy U = ½ k (r − l₀)² with r = q₀: the elastic pendulum's potential
/// without gravity, for the particle route (where gravity acts on the bob).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadialSpring {
    /// Spring constant.
    pub k: f64,
    /// Natural length.
    pub l0: f64,
}

impl Potential for RadialSpring {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let stretch = q[0] - self.l0;
        stretch * stretch * (0.5 * self.k)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// A dashpot along the first coordinate: Φ = ½ c q̇₀² (seed eq. 54), here the spring's
/// extension rate ṙ. Absent (free) when c = 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadialDamping {
    /// Damping coefficient.
    pub c: f64,
}

impl Dissipation for RadialDamping {
    fn dissipation<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        qd[0] * qd[0] * (0.5 * self.c)
    }
    fn is_present(&self) -> bool {
        self.c != 0.0
    }
}

impl Scene for ElasticPendulum {
    /// The damped system, whose dashpot is absent (not evaluated, not dissipative) at c = 0.
    type System = System<Self, Self, RadialDamping>;
    const INFO: SceneInfo = SceneInfo {
        name: "elastic_pendulum",
        doc: "A mass on a spring (stiffness ``k``, natural length ``l0``) swinging in gravity, \
              with an optional radial dashpot ``c``; coordinates ``r``, ``theta``.",
        parameters: &[
            Parameter::number("m", 1.0, "bob mass"),
            Parameter::number("k", 40.0, "spring stiffness"),
            Parameter::number("l0", 1.0, "natural length of the spring"),
            Parameter::number("g", 9.81, "gravitational acceleration"),
            Parameter::number("c", 0.0, "radial damping coefficient"),
        ],
        coordinates: Coordinates::Fixed(&["r", "theta"]),
        route: Route::Energy,
        exact: false,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        let n = |k| a.number(k);
        Ok(Self::new(n("m"), n("k"), n("l0"), n("g")).damped(n("c")))
    }
    fn drawing(_: &Arguments) -> Option<Drawing> {
        Some(Drawing::chain(1, false))
    }
}
