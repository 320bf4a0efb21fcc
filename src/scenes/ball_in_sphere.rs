//! A ball rolling inside a hollow sphere, in a vertical plane (seed Fig. 8, eq. 49–53).

use super::registry::{Arguments, Coordinates, Drawing, Parameter, Route, Scene, SceneInfo};
use super::rigid_disc;
use crate::energies::{KineticEnergy, Potential};
use crate::error::{Error, Result};
use crate::routes::{ParticleSystem, Particles, System};
use crate::scalar::Scalar;
use std::f64::consts::PI;

/// A ball of mass m, moment of inertia J and radius r₂ rolling without slipping on the inside of
/// a hollow sphere of radius r₁, in the vertical plane through its centre. The coordinate θ₁ is
/// the angle of the ball's centre from the bottom; rolling, (r₁ − r₂) θ₁ = r₂ θ₂ = s (eq. 49),
/// removes the ball's own rotation θ₂.
///
/// T = ½ m ṡ² + ½ J θ̇₂² = ½ (m + J/r₂²)(r₁ − r₂)² θ̇₁² (eq. 50, 52),
/// U = −m g (r₁ − r₂) cos θ₁ (eq. 51), Φ = 0, Q″ = 0; the equation of motion is eq. 53.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallInSphere {
    /// Ball mass.
    pub m: f64,
    /// Ball moment of inertia about its centre (⅖ m r₂² for a solid ball).
    pub j: f64,
    /// Radius of the hollow sphere.
    pub r1: f64,
    /// Radius of the ball.
    pub r2: f64,
    /// Gravitational acceleration.
    pub g: f64,
}

impl BallInSphere {
    /// A ball of mass `m`, inertia `j`, radius `r2` inside a sphere of radius `r1` in gravity `g`.
    pub fn new(m: f64, j: f64, r1: f64, r2: f64, g: f64) -> Self {
        Self { m, j, r1, r2, g }
    }

    /// The energy-route system.
    pub fn system(self) -> System<Self, Self> {
        System::new(1, self).with_potential(self)
    }

    /// The particle route, in gravity along −y: the ball as m − J/r₂² at its centre and J/(2r₂²)
    /// at each of two opposite points of its rim (same mass, centroid and moment of inertia, so
    /// the same T; see the [`Particles`] impl). The rim points show the ball's own rotation θ₂.
    pub fn particles(self) -> ParticleSystem<Self> {
        ParticleSystem::new(self).with_gravity([0.0, -self.g, 0.0])
    }

    /// The mass matrix (a 1 × 1 inertia) of eq. 52: (m + J/r₂²)(r₁ − r₂)².
    pub fn inertia(&self) -> f64 {
        let arm = self.r1 - self.r2;
        (self.m + self.j / (self.r2 * self.r2)) * arm * arm
    }

    /// Closed form, eq. 53: θ̈₁ = −m g (r₁ − r₂) sin θ₁ / ((m + J/r₂²)(r₁ − r₂)²).
    pub fn closed_form_accelerations(&self, q: &[f64], _qd: &[f64]) -> [f64; 1] {
        [-self.m * self.g * (self.r1 - self.r2) * q[0].sin() / self.inertia()]
    }

    /// The small-oscillation angular frequency of eq. 53 linearised (sin θ₁ ≈ θ₁):
    /// ω₀ = √(m g / ((m + J/r₂²)(r₁ − r₂))).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] unless m, g, r₂ > 0, J ≥ 0 and r₁ > r₂ (finite).
    pub fn small_oscillation_frequency(&self) -> Result<f64> {
        let Self { m, j, r1, r2, g } = *self;
        let ok = [m, j, r1, r2, g].iter().all(|x| x.is_finite())
            && m > 0.0
            && g > 0.0
            && r2 > 0.0
            && j >= 0.0
            && r1 > r2;
        if !ok {
            return Err(Error::InvalidInput {
                what: "ball-in-sphere parameters",
                why: format!(
                    "need m, g, r2 > 0, J ≥ 0 and r1 > r2; got m = {m}, J = {j}, r1 = {r1}, \
                     r2 = {r2}, g = {g}"
                ),
            });
        }
        Ok((m * g / ((m + j / (r2 * r2)) * (r1 - r2))).sqrt())
    }

    /// The exact period of eq. 53 released from rest at amplitude `theta0`:
    /// 4 K(sin(θ₀/2)) / ω₀, with K the complete elliptic integral of the first kind.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for invalid parameters (see
    /// [`small_oscillation_frequency`](Self::small_oscillation_frequency)) or |θ₀| ≥ π (the ball
    /// starting at or above the top never swings back).
    pub fn period(&self, theta0: f64) -> Result<f64> {
        let w0 = self.small_oscillation_frequency()?;
        if theta0.is_nan() || theta0.abs() >= PI {
            return Err(Error::InvalidInput {
                what: "amplitude",
                why: format!("θ0 = {theta0} must satisfy |θ0| < π for an oscillation"),
            });
        }
        Ok(4.0 * elliptic_k((0.5 * theta0).sin())? / w0)
    }
}

/// The complete elliptic integral of the first kind, K(k) = ∫₀^{π/2} dφ / √(1 − k² sin² φ), in
/// terms of the modulus k, by the arithmetic–geometric mean: K(k) = π / (2 AGM(1, √(1 − k²))).
/// The AGM converges quadratically, so a handful of steps give full precision.
///
/// # Errors
/// [`Error::InvalidInput`] unless |k| < 1 (K diverges at |k| = 1).
pub fn elliptic_k(k: f64) -> Result<f64> {
    if k.is_nan() || k.abs() >= 1.0 {
        return Err(Error::InvalidInput {
            what: "elliptic modulus",
            why: format!("k = {k} must satisfy |k| < 1"),
        });
    }
    // 1 − k² as (1 − k)(1 + k) keeps its digits when k is near 1.
    let (mut a, mut b) = (1.0_f64, ((1.0 - k.abs()) * (1.0 + k.abs())).sqrt());
    for _ in 0..64 {
        if (a - b).abs() <= 4.0 * f64::EPSILON * a {
            break;
        }
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
    }
    Ok(PI / (a + b))
}

/// Three points in the vertical plane, the sphere's centre at the origin: the ball's centre
/// c = (r₁ − r₂)(sin θ₁, −cos θ₁), then the rim points c ± r₂ (sin ψ, cos ψ) with
/// ψ = (r₁ − r₂) θ₁ / r₂ = θ₂ (eq. 49; the ball turns clockwise as θ₁ grows). Masses m − J/r₂²,
/// J/(2r₂²), J/(2r₂²): total m, centroid c and second moment J about c, hence
/// T = ½ m ṡ² + ½ J θ̇₂² (eq. 50) and in gravity U = m g c_y = eq. 51.
impl Particles for BallInSphere {
    const FIXED_DOF: Option<usize> = Some(1);
    fn dof(&self) -> usize {
        1
    }
    fn dim(&self) -> usize {
        2
    }
    fn count(&self) -> usize {
        3
    }
    fn mass(&self, k: usize) -> f64 {
        rigid_disc::mass(self.m, self.j, self.r2, k)
    }
    fn positions<D: Scalar>(&self, _t: D, q: &[D], r: &mut [D]) {
        let arm = self.r1 - self.r2;
        let (s1, c1) = q[0].sin_cos();
        rigid_disc::points(s1 * arm, -c1 * arm, q[0] * (arm / self.r2), self.r2, r);
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl KineticEnergy for BallInSphere {
    const FIXED_DOF: Option<usize> = Some(1);
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        qd[0] * qd[0] * (0.5 * self.inertia())
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

impl Potential for BallInSphere {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        -q[0].cos() * (self.m * self.g * (self.r1 - self.r2))
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Scene for BallInSphere {
    type System = System<Self, Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "ball_in_sphere",
        doc: "A ball of radius ``r2`` rolling inside a sphere of radius ``r1`` (seed eq. \
              49–53); coordinate ``theta`` from the bottom.",
        parameters: &[
            Parameter::number("m", 1.0, "mass of the ball"),
            Parameter::number("j", 0.016, "moment of inertia of the ball (⅖ m r₂² solid)"),
            Parameter::number("r1", 1.0, "radius of the sphere"),
            Parameter::number("r2", 0.2, "radius of the ball"),
            Parameter::number("g", 9.81, "gravitational acceleration"),
        ],
        coordinates: Coordinates::Fixed(&["theta"]),
        route: Route::Energy,
        exact: false,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        let n = |k| a.number(k);
        Ok(Self::new(n("m"), n("j"), n("r1"), n("r2"), n("g")).system())
    }
    fn drawing(a: &Arguments) -> Option<Drawing> {
        Some(Drawing {
            bodies: vec![[0, 1, 2]],
            circles: vec![[0.0, 0.0, a.number("r1")]],
            marks: vec![[0.0, 0.0]],
            trail: Some(vec![0]),
            ..Drawing::default()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::Dynamics;
    use approx::assert_relative_eq;
    use num_dual::Dual64;

    const BALLS: [(f64, f64, f64, f64, f64); 3] = [
        (1.0, 0.4, 5.0, 1.0, 9.81),   // solid: J = ⅖ m r₂²
        (0.3, 0.012, 1.0, 0.2, 9.81), // hollow shell: J = ⅔ m r₂²
        (2.0, 0.5, 0.8, 0.5, 1.62),   // J = m r₂²: massless centre
    ];

    #[test]
    fn accelerations_ball_in_sphere_both_routes() {
        for (m, j, r1, r2, g) in BALLS {
            let ball = BallInSphere::new(m, j, r1, r2, g);
            let (energy, particles) = (ball.system(), ball.particles());
            for k in 0..8 {
                let q = [-2.5 + 0.7 * k as f64];
                let qd = [0.9 - 0.3 * k as f64];
                let exact = ball.closed_form_accelerations(&q, &qd)[0];
                let a = energy.accelerations(0.0, &q, &qd).unwrap()[0];
                let b = particles.accelerations(0.0, &q, &qd).unwrap()[0];
                assert_relative_eq!(a, exact, max_relative = 1e-12);
                assert_relative_eq!(b, exact, max_relative = 1e-12);
                let (te, tp) = (energy.energy(0.0, &q, &qd), particles.energy(0.0, &q, &qd));
                assert_relative_eq!(te.unwrap(), tp.unwrap(), max_relative = 1e-12);
            }
        }
    }

    /// Rolling without slipping: the ball's point touching the sphere is at rest. Rim point 1
    /// points outwards along (sin θ₁, −cos θ₁) when ψ = π − θ₁, i.e. θ₁ = π r₂ / r₁.
    #[test]
    fn positions_ball_in_sphere_contact_at_rest() {
        for (m, j, r1, r2, g) in BALLS {
            let ball = BallInSphere::new(m, j, r1, r2, g);
            let th = std::f64::consts::PI * r2 / r1;
            let mut p = [Dual64::from(0.0); 6];
            Particles::positions(&ball, Dual64::from(0.0), &[Dual64::new(th, 1.0)], &mut p);
            assert_relative_eq!(p[2].re.hypot(p[3].re), r1, max_relative = 1e-14);
            assert!(p[2].eps.abs() < 1e-14 && p[3].eps.abs() < 1e-14);
            // The centre moves at (r₁ − r₂) per radian; the opposite rim point at twice that.
            let arm = r1 - r2;
            assert_relative_eq!(p[0].eps.hypot(p[1].eps), arm, max_relative = 1e-14);
            assert_relative_eq!(p[4].eps.hypot(p[5].eps), 2.0 * arm, max_relative = 1e-14);
        }
    }
}
