//! A charged particle in the plane, in a uniform magnetic field normal to it and an optional
//! uniform electric field in it: the reference problem for a velocity-dependent Lagrangian.

use super::registry::{
    Arguments, Coordinates, Parameter, Route, Scene, SceneInfo, State, exact_planar,
};
use crate::energies::{KineticEnergy, Potential};
use crate::error::{Error, Result};
use crate::routes::{CartesianForces, ParticleSystem, Particles, System};
use crate::scalar::Scalar;

/// Charge e and mass m at (x, y) in the field B ẑ (vector potential A = (B/2)(−y, x)) and the
/// electric field E = (E_x, E_y).
///
/// L = ½ m (ẋ² + ẏ²) + (eB/2)(x ẏ − y ẋ) − U: the term e q̇·A is linear in the velocities and
/// belongs in the kinetic part, T = ½ m v² + (eB/2)(x ẏ − y ẋ) (see [`KineticEnergy`]);
/// U = −e (E_x x + E_y y), Φ = 0, Q″ = 0. M = m I is constant but T depends on q, so the system
/// is not separable (the magnetic force is gyroscopic). The energy function h = q̇·p − L is
/// ½ m v² + U: the magnetic term drops out, as the magnetic force does no work.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChargedParticle {
    /// Mass.
    pub m: f64,
    /// Charge.
    pub e: f64,
    /// Magnetic field B along ẑ.
    pub b: f64,
    /// Electric field, x component.
    pub ex: f64,
    /// Electric field, y component.
    pub ey: f64,
}

impl ChargedParticle {
    /// A particle of mass `m` and charge `e` in the magnetic field `b` ẑ, no electric field.
    pub fn new(m: f64, e: f64, b: f64) -> Self {
        Self {
            m,
            e,
            b,
            ex: 0.0,
            ey: 0.0,
        }
    }

    /// Add the uniform electric field (E_x, E_y).
    pub fn with_electric_field(mut self, ex: f64, ey: f64) -> Self {
        self.ex = ex;
        self.ey = ey;
        self
    }

    /// The energy-route system: the magnetic field through the velocity-dependent T, the electric
    /// field through U (absent when E = 0).
    pub fn system(self) -> System<Self, Self> {
        System::new(2, self).with_potential(self)
    }

    /// The particle-route system: the Lorentz force e (E + v × B) as a Cartesian force on a free
    /// particle — Newton's form, with no vector potential.
    pub fn particles(self) -> ParticleSystem<Self, (), (), (), LorentzForce> {
        ParticleSystem::new(self).with_cartesian_forces(LorentzForce {
            e: self.e,
            b: self.b,
            ex: self.ex,
            ey: self.ey,
        })
    }

    /// Closed form: m ẍ = e B ẏ + e E_x, m ÿ = −e B ẋ + e E_y.
    pub fn closed_form_accelerations(&self, _q: &[f64], qd: &[f64]) -> [f64; 2] {
        let s = self.e / self.m;
        [
            s * (self.b * qd[1] + self.ex),
            s * (-self.b * qd[0] + self.ey),
        ]
    }

    /// The cyclotron angular frequency ω_c = e B / m (signed: positive ω_c turns the velocity
    /// clockwise).
    pub fn cyclotron_frequency(&self) -> f64 {
        self.e * self.b / self.m
    }

    /// The E × B drift velocity (E_y / B, −E_x / B), the same for every charge and mass.
    pub fn drift_velocity(&self) -> [f64; 2] {
        [self.ey / self.b, -self.ex / self.b]
    }

    /// The exact motion (q(t), q̇(t)) from q(0) = `q0`, q̇(0) = `v0`: the uniform drift
    /// v_d = (E_y/B, −E_x/B) plus the velocity u = q̇ − v_d turning at ω_c = eB/m,
    /// u(t) = (u_x cos ω_c t + u_y sin ω_c t, −u_x sin ω_c t + u_y cos ω_c t). With E = 0 the
    /// orbit is the circle of radius |v0|/|ω_c| about q0 + (v_{0y}, −v_{0x})/ω_c.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] unless m > 0 and e B ≠ 0 (finite).
    pub fn exact_solution(&self, q0: [f64; 2], v0: [f64; 2], t: f64) -> Result<[[f64; 2]; 2]> {
        let w = self.cyclotron_frequency();
        let finite = [self.m, self.e, self.b, self.ex, self.ey]
            .iter()
            .all(|x| x.is_finite());
        if !(finite && self.m > 0.0 && w != 0.0 && w.is_finite()) {
            return Err(Error::InvalidInput {
                what: "charged-particle parameters",
                why: format!(
                    "need finite m > 0 and e B ≠ 0 for gyration; got m = {}, e = {}, B = {}",
                    self.m, self.e, self.b
                ),
            });
        }
        let vd = self.drift_velocity();
        let u = [v0[0] - vd[0], v0[1] - vd[1]];
        let (s, c) = (w * t).sin_cos();
        // 1 − cos ω t written as 2 sin²(ω t / 2), exact near t = 0.
        let h = (0.5 * w * t).sin();
        let one_minus_c = 2.0 * h * h;
        let x = [
            q0[0] + vd[0] * t + (u[0] * s + u[1] * one_minus_c) / w,
            q0[1] + vd[1] * t + (u[1] * s - u[0] * one_minus_c) / w,
        ];
        let v = [vd[0] + u[0] * c + u[1] * s, vd[1] - u[0] * s + u[1] * c];
        Ok([x, v])
    }
}

impl KineticEnergy for ChargedParticle {
    const FIXED_DOF: Option<usize> = Some(2);
    fn kinetic<D: Scalar>(&self, _t: D, q: &[D], qd: &[D]) -> D {
        (qd[0] * qd[0] + qd[1] * qd[1]) * (0.5 * self.m)
            + (q[0] * qd[1] - q[1] * qd[0]) * (0.5 * self.e * self.b)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn depends_on_position(&self) -> bool {
        self.e != 0.0 && self.b != 0.0
    }
    fn constant_mass_matrix(&self) -> bool {
        true
    }
}

impl Potential for ChargedParticle {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        -(q[0] * self.ex + q[1] * self.ey) * self.e
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn is_present(&self) -> bool {
        self.ex != 0.0 || self.ey != 0.0
    }
}

impl Particles for ChargedParticle {
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

/// The Lorentz force e (E + v × B ẑ) = e (E_x + B v_y, E_y − B v_x) on planar particles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LorentzForce {
    /// Charge.
    pub e: f64,
    /// Magnetic field along ẑ.
    pub b: f64,
    /// Electric field, x component.
    pub ex: f64,
    /// Electric field, y component.
    pub ey: f64,
}

impl CartesianForces for LorentzForce {
    fn forces<D: Scalar>(&self, _t: D, _r: &[D], v: &[D], out: &mut [D]) {
        for (f, w) in out.chunks_exact_mut(2).zip(v.chunks_exact(2)) {
            f[0] += (w[1] * self.b + self.ex) * self.e;
            f[1] += (-w[0] * self.b + self.ey) * self.e;
        }
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn is_present(&self) -> bool {
        self.e != 0.0 && (self.b != 0.0 || self.ex != 0.0 || self.ey != 0.0)
    }
}

impl Scene for ChargedParticle {
    type System = System<Self, Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "charged_particle",
        doc: "A charge ``e`` of mass ``m`` in a magnetic field ``b`` normal to the plane and an \
              electric field (``ex``, ``ey``); coordinates ``x``, ``y``.",
        parameters: &[
            Parameter::number("m", 1.0, "mass"),
            Parameter::number("e", 1.0, "charge"),
            Parameter::number("b", 1.0, "magnetic field normal to the plane"),
            Parameter::number("ex", 0.0, "electric field, x component"),
            Parameter::number("ey", 0.0, "electric field, y component"),
        ],
        coordinates: Coordinates::Fixed(&["x", "y"]),
        route: Route::Energy,
        exact: true,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        Ok(Self::of(a).system())
    }
    fn exact(a: &Arguments, q0: &[f64], qd0: &[f64], t: f64) -> Result<State> {
        exact_planar(q0, qd0, |q0, v0| Self::of(a).exact_solution(q0, v0, t))
    }
}

impl ChargedParticle {
    fn of(a: &Arguments) -> Self {
        let n = |k| a.number(k);
        Self::new(n("m"), n("e"), n("b")).with_electric_field(n("ex"), n("ey"))
    }
}
