//! Two masses coupled by springs, driven harmonically: the forced two-degree-of-freedom system of
//! the seed (Fig. 5, eq. 41–44).

use super::registry::{
    Arguments, Coordinates, Drawn, Parameter, Positions, Route, Scene, SceneInfo, State,
    exact_planar,
};
use crate::energies::{GeneralizedForces, KineticEnergy, Potential};
use crate::error::{Error, Result};
use crate::routes::System;
use crate::scalar::Scalar;

/// Masses m₁, m₂ on springs k₁ (ground–m₁) and k₂ (m₁–m₂), coordinates the displacements
/// (x₁, x₂) from equilibrium, forced by f_i(t) = F_i cos Ω t.
///
/// T = ½ m₁ ẋ₁² + ½ m₂ ẋ₂² (eq. 41), U = ½ k₁ x₁² + ½ k₂ (x₂ − x₁)² (eq. 42),
/// Φ = 0, Q″ = (f₁(t), f₂(t)); the equations of motion are eq. 43–44. With F₁ = F₂ = 0 the
/// forcing reports itself absent and costs nothing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForcedTwoMass {
    /// First mass (attached to the ground by k₁).
    pub m1: f64,
    /// Second mass.
    pub m2: f64,
    /// Spring between the ground and m₁.
    pub k1: f64,
    /// Spring between m₁ and m₂.
    pub k2: f64,
    /// Force amplitude on m₁.
    pub f1: f64,
    /// Force amplitude on m₂.
    pub f2: f64,
    /// Forcing angular frequency Ω.
    pub omega: f64,
}

impl ForcedTwoMass {
    /// The free system (no forcing) with the given masses and springs.
    pub fn new(m1: f64, m2: f64, k1: f64, k2: f64) -> Self {
        Self {
            m1,
            m2,
            k1,
            k2,
            f1: 0.0,
            f2: 0.0,
            omega: 0.0,
        }
    }

    /// Add the harmonic forcing f₁ = F₁ cos Ω t on m₁ and f₂ = F₂ cos Ω t on m₂.
    pub fn with_forcing(mut self, f1: f64, f2: f64, omega: f64) -> Self {
        self.f1 = f1;
        self.f2 = f2;
        self.omega = omega;
        self
    }

    /// The energy-route system: T, U and the forcing as generalized forces.
    pub fn system(self) -> System<Self, Self, (), Self> {
        System::new(2, self).with_potential(self).with_forces(self)
    }

    /// The forces (f₁(t), f₂(t)).
    pub fn forcing(&self, t: f64) -> [f64; 2] {
        let c = (self.omega * t).cos();
        [self.f1 * c, self.f2 * c]
    }

    /// Closed form, eq. 43–44 solved for the accelerations:
    /// ẍ₁ = (f₁ − k₁ x₁ + k₂ (x₂ − x₁)) / m₁, ẍ₂ = (f₂ − k₂ (x₂ − x₁)) / m₂.
    pub fn closed_form_accelerations(&self, t: f64, q: &[f64], _qd: &[f64]) -> [f64; 2] {
        let [f1, f2] = self.forcing(t);
        let stretch = q[1] - q[0];
        [
            (f1 - self.k1 * q[0] + self.k2 * stretch) / self.m1,
            (f2 - self.k2 * stretch) / self.m2,
        ]
    }

    /// The natural angular frequencies ω₁ ≤ ω₂: the roots of det(K − ω² M) = 0,
    /// m₁ m₂ ω⁴ − (m₁ k₂ + m₂ (k₁ + k₂)) ω² + k₁ k₂ = 0.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] unless the masses and springs are positive and finite.
    pub fn natural_frequencies(&self) -> Result<[f64; 2]> {
        self.check()?;
        let Self { m1, m2, k1, k2, .. } = *self;
        let b = m1 * k2 + m2 * (k1 + k2);
        let root = (b * b - 4.0 * m1 * m2 * k1 * k2).sqrt();
        // The larger root directly; the smaller from the product of the roots (no cancellation).
        let w2_high = (b + root) / (2.0 * m1 * m2);
        let w2_low = k1 * k2 / (m1 * m2 * w2_high);
        Ok([w2_low.sqrt(), w2_high.sqrt()])
    }

    /// The exact solution (x(t), ẋ(t)) of eq. 43–44 from x(0) = `x0`, ẋ(0) = `v0`: the steady
    /// response X cos Ω t with (K − Ω² M) X = F, plus the free modal vibration that matches the
    /// initial state, Σᵢ φᵢ (aᵢ cos ωᵢ t + bᵢ sin ωᵢ t).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for non-positive or non-finite parameters, or a forcing frequency
    /// within a relative 1e-8 of a natural frequency (resonance: the steady response is unbounded
    /// and the solution has a secular term this formula does not cover).
    pub fn exact_solution(&self, x0: [f64; 2], v0: [f64; 2], t: f64) -> Result<[[f64; 2]; 2]> {
        let w = self.natural_frequencies()?;
        let Self {
            m1,
            m2,
            k1,
            k2,
            f1,
            f2,
            omega,
        } = *self;
        // Steady response amplitude X from (K − Ω² M) X = F.
        let forced = f1 != 0.0 || f2 != 0.0;
        let amp = if forced {
            if !omega.is_finite() || !f1.is_finite() || !f2.is_finite() {
                return Err(Error::InvalidInput {
                    what: "forcing",
                    why: format!("amplitudes ({f1}, {f2}) and Ω = {omega} must be finite"),
                });
            }
            let w2 = omega * omega;
            if w.iter().any(|wi| (w2 - wi * wi).abs() <= 1e-8 * wi * wi) {
                return Err(Error::InvalidInput {
                    what: "forcing frequency",
                    why: format!(
                        "Ω = {omega} is at a natural frequency {w:?}: resonance has no bounded \
                         steady response"
                    ),
                });
            }
            let (a, b, d) = (k1 + k2 - w2 * m1, -k2, k2 - w2 * m2);
            let det = a * d - b * b;
            [(d * f1 - b * f2) / det, (a * f2 - b * f1) / det]
        } else {
            [0.0, 0.0]
        };
        let (s, c) = (omega * t).sin_cos();
        let mut x = [amp[0] * c, amp[1] * c];
        let mut v = [-amp[0] * omega * s, -amp[1] * omega * s];
        // Free vibration in the modes φᵢ = (1, rᵢ), rᵢ = (k₁ + k₂ − ωᵢ² m₁) / k₂, which are
        // M-orthogonal; the initial state of the homogeneous part is (x0 − X, v0).
        let dx = [x0[0] - amp[0], x0[1] - amp[1]];
        for wi in w {
            let r = (k1 + k2 - wi * wi * m1) / k2;
            let norm = m1 + m2 * r * r;
            let a = (m1 * dx[0] + m2 * r * dx[1]) / norm;
            let b = (m1 * v0[0] + m2 * r * v0[1]) / (norm * wi);
            let (s, c) = (wi * t).sin_cos();
            let mode_x = a * c + b * s;
            let mode_v = wi * (b * c - a * s);
            x[0] += mode_x;
            x[1] += r * mode_x;
            v[0] += mode_v;
            v[1] += r * mode_v;
        }
        Ok([x, v])
    }

    fn check(&self) -> Result<()> {
        let p = [self.m1, self.m2, self.k1, self.k2];
        if p.iter().all(|x| x.is_finite() && *x > 0.0) {
            Ok(())
        } else {
            Err(Error::InvalidInput {
                what: "two-mass parameters",
                why: format!("masses and springs (m1, m2, k1, k2) = {p:?} must be positive"),
            })
        }
    }
}

impl KineticEnergy for ForcedTwoMass {
    const FIXED_DOF: Option<usize> = Some(2);
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        (qd[0] * qd[0] * self.m1 + qd[1] * qd[1] * self.m2) * 0.5
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

impl Potential for ForcedTwoMass {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let stretch = q[1] - q[0];
        (q[0] * q[0] * self.k1 + stretch * stretch * self.k2) * 0.5
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl GeneralizedForces for ForcedTwoMass {
    fn forces<D: Scalar>(&self, t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        let c = (t * self.omega).cos();
        out[0] += c * self.f1;
        out[1] += c * self.f2;
    }
    fn depends_on_time(&self) -> bool {
        self.omega != 0.0
    }
    fn is_present(&self) -> bool {
        self.f1 != 0.0 || self.f2 != 0.0
    }
}

impl Scene for ForcedTwoMass {
    type System = System<Self, Self, (), Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "forced_two_mass",
        doc: "Two masses on springs k₁ (ground–m₁) and k₂ (m₁–m₂), forced by fᵢ cos Ω t (seed \
              eq. 41–44); coordinates ``x1``, ``x2``.",
        parameters: &[
            Parameter::number("m1", 1.0, "first mass"),
            Parameter::number("m2", 0.5, "second mass"),
            Parameter::number("k1", 10.0, "stiffness of the spring from the ground to m₁"),
            Parameter::number("k2", 5.0, "stiffness of the spring from m₁ to m₂"),
            Parameter::number("f1", 0.0, "forcing amplitude on m₁"),
            Parameter::number("f2", 0.0, "forcing amplitude on m₂"),
            Parameter::number("omega", 0.0, "forcing angular frequency Ω"),
        ],
        coordinates: Coordinates::Fixed(&["x1", "x2"]),
        route: Route::Energy,
        exact: true,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        Ok(Self::of(a).system())
    }
    fn exact(a: &Arguments, q0: &[f64], qd0: &[f64], t: f64) -> Result<State> {
        exact_planar(q0, qd0, |x0, v0| Self::of(a).exact_solution(x0, v0, t))
    }
}

impl ForcedTwoMass {
    fn of(a: &Arguments) -> Self {
        let n = |k| a.number(k);
        Self::new(n("m1"), n("m2"), n("k1"), n("k2")).with_forcing(n("f1"), n("f2"), n("omega"))
    }
}

/// Masses on springs along a line: nothing to draw.
impl<U, R, Q> Drawn for System<ForcedTwoMass, U, R, Q> {
    fn positions(&self, _t: &[f64], _q: &[f64]) -> Option<Positions> {
        None
    }
}
