//! The planar Kepler problem in Cartesian coordinates: the reference problem for long-time
//! energy and angular-momentum behaviour of integrators.

use super::registry::{
    Arguments, Coordinates, Drawing, Parameter, Route, Scene, SceneInfo, State, exact_planar,
};
use crate::energies::{KineticEnergy, Potential};
use crate::error::{Error, Result};
use crate::routes::{ParticleSystem, Particles, System};
use crate::scalar::Scalar;
use std::f64::consts::PI;

/// A body of mass m attracted to a fixed centre with gravitational parameter μ, coordinates
/// (x, y).
///
/// T = ½ m (ẋ² + ẏ²), U = −μ m / r with r = √(x² + y²), Φ = 0, Q″ = 0. T has a constant mass
/// matrix and no position dependence, so the system is separable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kepler {
    /// Mass of the orbiting body.
    pub m: f64,
    /// Gravitational parameter μ = G M of the centre.
    pub mu: f64,
}

impl Kepler {
    /// A body of mass `m` around a centre of gravitational parameter `mu`.
    pub fn new(m: f64, mu: f64) -> Self {
        Self { m, mu }
    }

    /// The energy-route system.
    pub fn system(self) -> System<Self, Self> {
        System::new(2, self).with_potential(self)
    }

    /// The particle-route system: one particle at r = (x, y) in the potential U.
    pub fn particles(self) -> ParticleSystem<Self, Self> {
        ParticleSystem::new(self).with_potential(self)
    }

    /// Closed form: r̈ = −μ r / |r|³.
    pub fn closed_form_accelerations(&self, q: &[f64], _qd: &[f64]) -> [f64; 2] {
        let r2 = q[0] * q[0] + q[1] * q[1];
        let s = -self.mu / (r2 * r2.sqrt());
        [s * q[0], s * q[1]]
    }

    /// The state (q, q̇) at periapsis of the orbit with semi-major axis `a` and eccentricity `e`:
    /// r = (a (1 − e), 0), v = (0, √(μ (1 + e) / (a (1 − e)))), moving counter-clockwise.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] unless a > 0, 0 ≤ e < 1 (a bound orbit) and μ > 0.
    pub fn periapsis_state(&self, a: f64, e: f64) -> Result<([f64; 2], [f64; 2])> {
        self.check_orbit(a, e)?;
        let rp = a * (1.0 - e);
        Ok(([rp, 0.0], [0.0, (self.mu * (1.0 + e) / rp).sqrt()]))
    }

    /// The exact state (q, q̇) at time `t` after periapsis on the orbit of [`Kepler::periapsis_state`]:
    /// Kepler's equation E − e sin E = n t (n = √(μ/a³)) by Newton, then
    /// q = a (cos E − e, √(1−e²) sin E) and q̇ = a n (−sin E, √(1−e²) cos E) / (1 − e cos E).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] unless a > 0, 0 ≤ e < 1, μ > 0 and t is finite.
    pub fn exact_state(&self, a: f64, e: f64, t: f64) -> Result<([f64; 2], [f64; 2])> {
        self.check_orbit(a, e)?;
        if !t.is_finite() {
            return Err(Error::InvalidInput {
                what: "t",
                why: format!("{t} is not finite"),
            });
        }
        let n = (self.mu / (a * a * a)).sqrt();
        let mean = (n * t).rem_euclid(2.0 * PI);
        let mut ecc = mean + e * mean.sin();
        for _ in 0..60 {
            let d = (ecc - e * ecc.sin() - mean) / (1.0 - e * ecc.cos());
            ecc -= d;
            if d.abs() < 1e-16 {
                break;
            }
        }
        let (s, c) = ecc.sin_cos();
        let b = (1.0 - e * e).sqrt();
        let rate = a * n / (1.0 - e * c);
        Ok(([a * (c - e), a * b * s], [-s * rate, b * c * rate]))
    }

    /// The exact state (q, q̇) at time `t` of the bound orbit through (`q0`, `v0`) at t = 0:
    /// the orbit's elements from the state (a from the energy, the eccentricity vector e, the
    /// eccentric anomaly E₀ from cos E₀ ∝ 1 − r/a and sin E₀ ∝ q·v/√(μ a)), then
    /// [`Kepler::exact_state`] at the time since periapsis, turned to the periapsis direction
    /// (and mirrored for a clockwise orbit). A circular orbit takes its periapsis at `q0`.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] unless the orbit is bound (negative energy), not radial (non-zero
    /// angular momentum), μ > 0 and the inputs are finite.
    pub fn exact_from(&self, q0: [f64; 2], v0: [f64; 2], t: f64) -> Result<([f64; 2], [f64; 2])> {
        let mu = self.mu;
        let r = q0[0].hypot(q0[1]);
        let v2 = v0[0] * v0[0] + v0[1] * v0[1];
        let h = q0[0] * v0[1] - q0[1] * v0[0];
        let energy = 0.5 * v2 - mu / r;
        if !(mu.is_finite() && mu > 0.0 && r > 0.0 && energy < 0.0 && h != 0.0) {
            return Err(Error::InvalidInput {
                what: "orbit",
                why: format!(
                    "the exact solution needs a bound, non-radial orbit about μ = {mu} > 0; \
                     got q0 = {q0:?}, v0 = {v0:?}"
                ),
            });
        }
        let a = -mu / (2.0 * energy);
        let rv = q0[0] * v0[0] + q0[1] * v0[1];
        let ev = [
            ((v2 - mu / r) * q0[0] - rv * v0[0]) / mu,
            ((v2 - mu / r) * q0[1] - rv * v0[1]) / mu,
        ];
        let e = ev[0].hypot(ev[1]);
        // e cos E₀ and e sin E₀; for a circle the periapsis is q0 itself (E₀ = 0).
        let (periapsis, anomaly, e) = if e < 1e-12 {
            (q0[1].atan2(q0[0]), 0.0, 0.0)
        } else {
            let anomaly = (rv / (mu * a).sqrt()).atan2(1.0 - r / a);
            (ev[1].atan2(ev[0]), anomaly, e.min(1.0 - f64::EPSILON))
        };
        let n = (mu / (a * a * a)).sqrt();
        let since = (anomaly - e * anomaly.sin()) / n;
        let (q, v) = self.exact_state(a, e, t + since)?;
        let turn = if h < 0.0 { -1.0 } else { 1.0 };
        let (s, c) = periapsis.sin_cos();
        let rotate = |p: [f64; 2]| [c * p[0] - s * turn * p[1], s * p[0] + c * turn * p[1]];
        Ok((rotate(q), rotate(v)))
    }

    /// The orbital period 2π √(a³/μ) (Kepler's third law).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] unless a > 0 and μ > 0.
    pub fn period(&self, a: f64) -> Result<f64> {
        self.check_orbit(a, 0.0)?;
        Ok(2.0 * PI * (a * a * a / self.mu).sqrt())
    }

    /// The energy of a bound orbit, E = T + U = −μ m / (2a).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] unless a > 0 and μ > 0.
    pub fn orbit_energy(&self, a: f64) -> Result<f64> {
        self.check_orbit(a, 0.0)?;
        Ok(-self.mu * self.m / (2.0 * a))
    }

    /// The angular momentum of the orbit, m √(μ a (1 − e²)).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] unless a > 0, 0 ≤ e < 1 and μ > 0.
    pub fn orbit_angular_momentum(&self, a: f64, e: f64) -> Result<f64> {
        self.check_orbit(a, e)?;
        Ok(self.m * (self.mu * a * (1.0 - e) * (1.0 + e)).sqrt())
    }

    /// The angular momentum m (x ẏ − y ẋ) of a state: conserved by the exact flow.
    pub fn angular_momentum(&self, q: &[f64], qd: &[f64]) -> f64 {
        self.m * (q[0] * qd[1] - q[1] * qd[0])
    }

    fn check_orbit(&self, a: f64, e: f64) -> Result<()> {
        let ok = a.is_finite() && a > 0.0 && (0.0..1.0).contains(&e);
        if !ok {
            return Err(Error::InvalidInput {
                what: "orbit",
                why: format!("need a > 0 and 0 ≤ e < 1 for a bound orbit; got a = {a}, e = {e}"),
            });
        }
        if !(self.mu.is_finite() && self.mu > 0.0) {
            return Err(Error::InvalidInput {
                what: "gravitational parameter",
                why: format!("μ = {} must be positive", self.mu),
            });
        }
        Ok(())
    }
}

impl KineticEnergy for Kepler {
    const FIXED_DOF: Option<usize> = Some(2);
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        (qd[0] * qd[0] + qd[1] * qd[1]) * (0.5 * self.m)
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

impl Potential for Kepler {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        (q[0] * q[0] + q[1] * q[1]).sqrt().recip() * (-self.mu * self.m)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Particles for Kepler {
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
        r[0] = q[0];
        r[1] = q[1];
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Scene for Kepler {
    type System = System<Self, Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "kepler",
        doc: "A body of mass ``m`` around a centre of gravitational parameter ``mu``; \
              coordinates ``x``, ``y``.",
        parameters: &[
            Parameter::number("m", 1.0, "mass of the body"),
            Parameter::number("mu", 1.0, "gravitational parameter μ = G M of the centre"),
        ],
        coordinates: Coordinates::Fixed(&["x", "y"]),
        route: Route::Energy,
        exact: true,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        Ok(Self::new(a.number("m"), a.number("mu")).system())
    }
    fn drawing(_: &Arguments) -> Option<Drawing> {
        Some(Drawing {
            marks: vec![[0.0, 0.0]],
            ..Drawing::default()
        })
    }
    fn exact(a: &Arguments, q0: &[f64], qd0: &[f64], t: f64) -> Result<State> {
        let kepler = Self::new(a.number("m"), a.number("mu"));
        exact_planar(q0, qd0, |q0, v0| {
            kepler.exact_from(q0, v0, t).map(|(q, v)| [q, v])
        })
    }
}
