//! The viscously damped oscillator: the one-coordinate case of Rayleigh's dissipation function
//! (seed §4, eq. 54–55).

use super::registry::{
    Arguments, Coordinates, Drawn, Parameter, Positions, Route, Scene, SceneInfo, State,
};
use crate::energies::{Dissipation, KineticEnergy, Potential};
use crate::error::{Error, Result};
use crate::routes::System;
use crate::scalar::Scalar;

/// A mass m on a spring k with a dashpot c, coordinate x.
///
/// T = ½ m ẋ², U = ½ k x², Φ = ½ c ẋ² (eq. 54), Q″ = 0; eq. 55 gives m ẍ + c ẋ + k x = 0.
/// With c = 0 the dissipation reports itself absent and costs nothing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DampedOscillator {
    /// Mass.
    pub m: f64,
    /// Spring constant.
    pub k: f64,
    /// Damping coefficient.
    pub c: f64,
}

impl DampedOscillator {
    /// An oscillator of mass `m`, stiffness `k` and damping `c`.
    pub fn new(m: f64, k: f64, c: f64) -> Self {
        Self { m, k, c }
    }

    /// The energy-route system: T, U and Φ.
    pub fn system(self) -> System<Self, Self, Self> {
        System::new(1, self)
            .with_potential(self)
            .with_dissipation(self)
    }

    /// Closed form of eq. 55: ẍ = −(c ẋ + k x) / m.
    pub fn closed_form_accelerations(&self, q: &[f64], qd: &[f64]) -> [f64; 1] {
        [-(self.c * qd[0] + self.k * q[0]) / self.m]
    }

    /// The undamped angular frequency ω₀ = √(k/m).
    pub fn natural_frequency(&self) -> f64 {
        (self.k / self.m).sqrt()
    }

    /// The damping ratio ζ = c / (2 √(m k)): below 1 under-damped, 1 critical, above 1
    /// over-damped.
    pub fn damping_ratio(&self) -> f64 {
        self.c / (2.0 * (self.m * self.k).sqrt())
    }

    /// The exact motion (x(t), ẋ(t)) from x(0) = `x0`, ẋ(0) = `v0`. With γ = c/(2m) and
    /// β² = γ² − ω₀²,
    ///
    /// x = e^{−γt} (x0 f(t) + (v0 + γ x0) g(t)),  ẋ = e^{−γt} (v0 f(t) − (ω₀² x0 + γ v0) g(t)),
    ///
    /// where (f, g) = (cos ω_d t, sin ω_d t / ω_d) with ω_d² = −β² when under-damped,
    /// (1, t) when critically damped and (cosh βt, sinh βt / β) when over-damped. Writing g with
    /// the division keeps the formula accurate right up to critical damping from either side.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] unless m > 0, k ≥ 0 and c are finite.
    pub fn exact_solution(&self, x0: f64, v0: f64, t: f64) -> Result<(f64, f64)> {
        let Self { m, k, c } = *self;
        if !(m.is_finite() && k.is_finite() && c.is_finite() && m > 0.0 && k >= 0.0) {
            return Err(Error::InvalidInput {
                what: "oscillator parameters",
                why: format!("need finite m > 0, k ≥ 0 and c; got m = {m}, k = {k}, c = {c}"),
            });
        }
        let gamma = c / (2.0 * m);
        let w02 = k / m;
        let beta2 = gamma * gamma - w02;
        // (e^{−γt} f, e^{−γt} g), each product formed without overflow.
        let (f, g) = if beta2 < 0.0 {
            let wd = (-beta2).sqrt();
            let (s, co) = (wd * t).sin_cos();
            let decay = (-gamma * t).exp();
            (decay * co, decay * s / wd)
        } else if beta2 > 0.0 {
            let b = beta2.sqrt();
            if (b * t).abs() < 1.0 {
                let decay = (-gamma * t).exp();
                (decay * (b * t).cosh(), decay * (b * t).sinh() / b)
            } else {
                // Far from critical in βt: the two real exponentials cannot cancel badly.
                // β − γ = −ω₀²/(β + γ) without cancellation.
                let slow = (-w02 / (b + gamma) * t).exp();
                let fast = (-(b + gamma) * t).exp();
                (0.5 * (slow + fast), 0.5 * (slow - fast) / b)
            }
        } else {
            let decay = (-gamma * t).exp();
            (decay, decay * t)
        };
        Ok((
            x0 * f + (v0 + gamma * x0) * g,
            v0 * f - (w02 * x0 + gamma * v0) * g,
        ))
    }
}

impl KineticEnergy for DampedOscillator {
    const FIXED_DOF: Option<usize> = Some(1);
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        qd[0] * qd[0] * (0.5 * self.m)
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

impl Potential for DampedOscillator {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[0] * q[0] * (0.5 * self.k)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Dissipation for DampedOscillator {
    fn dissipation<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        qd[0] * qd[0] * (0.5 * self.c)
    }
    fn is_present(&self) -> bool {
        self.c != 0.0
    }
}

impl Scene for DampedOscillator {
    type System = System<Self, Self, Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "damped_oscillator",
        doc: "m ẍ + c ẋ + k x = 0 from Rayleigh's Φ = ½ c ẋ² (seed eq. 54–55); coordinate \
              ``x``.",
        parameters: &[
            Parameter::number("m", 1.0, "mass"),
            Parameter::number("k", 4.0, "spring stiffness"),
            Parameter::number("c", 0.4, "damping coefficient"),
        ],
        coordinates: Coordinates::Fixed(&["x"]),
        route: Route::Energy,
        exact: true,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        Ok(Self::of(a).system())
    }
    fn exact(a: &Arguments, q0: &[f64], qd0: &[f64], t: f64) -> Result<State> {
        let (x, v) = Self::of(a).exact_solution(q0[0], qd0[0], t)?;
        Ok((vec![x], vec![v]))
    }
}

impl DampedOscillator {
    fn of(a: &Arguments) -> Self {
        Self::new(a.number("m"), a.number("k"), a.number("c"))
    }
}

/// A mass on a spring along a line: nothing to draw.
impl<U, R, Q> Drawn for System<DampedOscillator, U, R, Q> {
    fn positions(&self, _t: &[f64], _q: &[f64]) -> Option<Positions> {
        None
    }
}
