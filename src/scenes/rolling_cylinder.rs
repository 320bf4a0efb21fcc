//! A cylinder rolling without slipping down an incline (seed Fig. 7, eq. 45–48).

use super::registry::{Arguments, Coordinates, Drawing, Parameter, Route, Scene, SceneInfo, State};
use super::rigid_disc;
use crate::energies::{KineticEnergy, Potential};
use crate::error::Result;
use crate::routes::{ParticleSystem, Particles, System};
use crate::scalar::Scalar;

/// A cylinder of mass m, moment of inertia J about its axis and radius r rolling without
/// slipping down a slope of angle α; the coordinate x is the distance its centre has travelled
/// down the slope, and the rolling constraint x = r θ (eq. 45) removes the rotation angle.
///
/// T = ½ m ẋ² + ½ J θ̇² = ½ (m + J/r²) ẋ² (eq. 46), U = −m g x sin α (eq. 47), Φ = 0, Q″ = 0.
/// The contact forces do no work and never appear (eq. 48).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RollingCylinder {
    /// Mass.
    pub m: f64,
    /// Moment of inertia about the axis (½ m r² for a solid cylinder, m r² for a thin tube).
    pub j: f64,
    /// Radius.
    pub r: f64,
    /// Gravitational acceleration.
    pub g: f64,
    /// Slope angle α in radians.
    pub alpha: f64,
}

impl RollingCylinder {
    /// A cylinder with mass `m`, moment of inertia `j` and radius `r` on a slope of angle
    /// `alpha` in gravity `g`.
    pub fn new(m: f64, j: f64, r: f64, g: f64, alpha: f64) -> Self {
        Self { m, j, r, g, alpha }
    }

    /// The energy-route system.
    pub fn system(self) -> System<Self, Self> {
        System::new(1, self).with_potential(self)
    }

    /// The particle route, in gravity along −y: the plane motion of a rigid body has the kinetic
    /// energy of any point masses with its mass, centroid and moment of inertia, so the cylinder
    /// is m − J/r² at its centre and J/(2r²) at each of two opposite rim points (see the
    /// [`Particles`] impl). The rim points show the rotation x/r when the scene is drawn.
    pub fn particles(self) -> ParticleSystem<Self> {
        ParticleSystem::new(self).with_gravity([0.0, -self.g, 0.0])
    }

    /// The effective mass m + J/r² of eq. 48.
    pub fn effective_mass(&self) -> f64 {
        self.m + self.j / (self.r * self.r)
    }

    /// The constant acceleration from eq. 48: ẍ = g sin α / (1 + J/(m r²)).
    pub fn acceleration(&self) -> f64 {
        self.g * self.alpha.sin() / (1.0 + self.j / (self.m * self.r * self.r))
    }

    /// Closed form, eq. 48: ẍ = g sin α / (1 + J/(m r²)) whatever the state.
    pub fn closed_form_accelerations(&self, _q: &[f64], _qd: &[f64]) -> [f64; 1] {
        [self.acceleration()]
    }

    /// The exact motion (x(t), ẋ(t)) from x(0) = `x0`, ẋ(0) = `v0`:
    /// x = x0 + v0 t + ½ ẍ t², ẋ = v0 + ẍ t.
    pub fn exact_solution(&self, x0: f64, v0: f64, t: f64) -> (f64, f64) {
        let a = self.acceleration();
        (x0 + v0 * t + 0.5 * a * t * t, v0 + a * t)
    }
}

impl KineticEnergy for RollingCylinder {
    const FIXED_DOF: Option<usize> = Some(1);
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        qd[0] * qd[0] * (0.5 * self.effective_mass())
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

impl Potential for RollingCylinder {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[0] * (-self.m * self.g * self.alpha.sin())
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// Three points in the vertical plane of the slope, which descends along (cos α, −sin α) from
/// the origin (the centre's position at x = 0): the centre c = x (cos α, −sin α), then the rim
/// points c ± r (sin ψ, cos ψ) with ψ = α + x/r — the rotation x = r θ of eq. 45, clockwise as
/// the cylinder rolls down. Masses m − J/r², J/(2r²), J/(2r²): total m, centroid c and second
/// moment J about c, hence T = ½ m ẋ² + ½ J θ̇² (eq. 46), and in gravity U = m g c_y = eq. 47.
impl Particles for RollingCylinder {
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
        rigid_disc::mass(self.m, self.j, self.r, k)
    }
    fn positions<D: Scalar>(&self, _t: D, q: &[D], r: &mut [D]) {
        let (sa, ca) = self.alpha.sin_cos();
        let psi = q[0] / self.r + self.alpha;
        rigid_disc::points(q[0] * ca, -q[0] * sa, psi, self.r, r);
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Scene for RollingCylinder {
    type System = System<Self, Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "rolling_cylinder",
        doc: "A cylinder rolling without slipping down a slope of angle ``alpha`` (seed eq. \
              45–48); coordinate ``x`` along the slope.",
        parameters: &[
            Parameter::number("m", 1.0, "mass"),
            Parameter::number(
                "j",
                0.005,
                "moment of inertia about the axis (½ m r² solid)",
            ),
            Parameter::number("r", 0.1, "radius"),
            Parameter::number("g", 9.81, "gravitational acceleration"),
            Parameter::number("alpha", 0.3, "slope angle (radians)"),
        ],
        coordinates: Coordinates::Fixed(&["x"]),
        route: Route::Energy,
        exact: true,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        Ok(Self::of(a).system())
    }
    fn drawing(a: &Arguments) -> Option<Drawing> {
        // The slope is the line through −r n, n = (sin α, cos α), along (cos α, −sin α).
        let (r, (sa, ca)) = (a.number("r"), a.number("alpha").sin_cos());
        Some(Drawing {
            bodies: vec![[0, 1, 2]],
            lines: vec![[-r * sa, -r * ca, ca, -sa]],
            trail: Some(vec![0]),
            ..Drawing::default()
        })
    }
    fn exact(a: &Arguments, q0: &[f64], qd0: &[f64], t: f64) -> Result<State> {
        let (x, v) = Self::of(a).exact_solution(q0[0], qd0[0], t);
        Ok((vec![x], vec![v]))
    }
}

impl RollingCylinder {
    fn of(a: &Arguments) -> Self {
        let n = |k| a.number(k);
        Self::new(n("m"), n("j"), n("r"), n("g"), n("alpha"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::Dynamics;
    use approx::assert_relative_eq;
    use num_dual::Dual64;

    const CYLINDERS: [(f64, f64, f64, f64, f64); 3] = [
        (2.0, 0.09, 0.3, 9.81, 0.4),  // solid: J = ½ m r²
        (1.5, 0.24, 0.4, 9.81, 0.25), // thin tube: J = m r², massless centre
        (0.7, 0.01, 0.5, 3.7, -0.6),  // slope the other way
    ];

    #[test]
    fn accelerations_rolling_cylinder_both_routes() {
        for (m, j, r, g, alpha) in CYLINDERS {
            let cyl = RollingCylinder::new(m, j, r, g, alpha);
            let (energy, particles) = (cyl.system(), cyl.particles());
            let exact = cyl.acceleration();
            for k in 0..8 {
                let q = [0.9 * k as f64 - 2.0];
                let qd = [1.3 - 0.4 * k as f64];
                let a = energy.accelerations(0.0, &q, &qd).unwrap()[0];
                let b = particles.accelerations(0.0, &q, &qd).unwrap()[0];
                assert_relative_eq!(a, exact, max_relative = 1e-12);
                assert_relative_eq!(b, exact, max_relative = 1e-12);
                // The same T and U, not just the same equation of motion.
                let (te, tp) = (energy.energy(0.0, &q, &qd), particles.energy(0.0, &q, &qd));
                assert_relative_eq!(te.unwrap(), tp.unwrap(), max_relative = 1e-12);
            }
        }
    }

    /// Rolling without slipping: the rim point touching the slope is at rest. Rim point 1 points
    /// along −n = −(sin α, cos α), onto the slope, when ψ = α + π, i.e. x = π r.
    #[test]
    fn positions_rolling_cylinder_contact_at_rest() {
        for (m, j, r, g, alpha) in CYLINDERS {
            let cyl = RollingCylinder::new(m, j, r, g, alpha);
            let x = std::f64::consts::PI * r;
            let mut p = [Dual64::from(0.0); 6];
            Particles::positions(&cyl, Dual64::from(0.0), &[Dual64::new(x, 1.0)], &mut p);
            // The contact point lies on the slope line through −r n along (cos α, −sin α).
            let (sa, ca) = alpha.sin_cos();
            let (px, py) = (p[2].re + r * sa, p[3].re + r * ca);
            assert_relative_eq!(px * sa + py * ca, 0.0, epsilon = 1e-14);
            assert!(p[2].eps.abs() < 1e-15 && p[3].eps.abs() < 1e-15);
            // The centre moves with dx/dx = 1 along the slope; the top point at twice that.
            assert_relative_eq!(p[0].eps, ca, epsilon = 1e-15);
            assert_relative_eq!(p[1].eps, -sa, epsilon = 1e-15);
            assert_relative_eq!(p[4].eps, 2.0 * ca, epsilon = 1e-14);
            assert_relative_eq!(p[5].eps, -2.0 * sa, epsilon = 1e-14);
        }
    }
}
