//! Kinetic energy T(t, q, q̇).

use crate::scalar::Scalar;

/// The kinetic energy T(t, q, q̇) of a system in generalized coordinates (seed eq. 1, 38).
///
/// Terms linear in q̇ belong here too: a velocity-dependent potential such as a charged particle's
/// `q̇·A(q)` or the Coriolis terms of a rotating frame make T = T₂ + T₁ + T₀, and the equations of
/// motion and the energy function h = q̇·p − L come out right.
///
/// The three structure methods let the equations of motion skip work. Their defaults are the
/// safe general case; a model that overrides them must tell the truth.
pub trait KineticEnergy {
    /// T at time `t`, coordinates `q` and velocities `qd`.
    fn kinetic<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D;

    /// Whether T depends on `t` explicitly (rheonomic constraints, a driven support).
    fn depends_on_time(&self) -> bool {
        true
    }

    /// Whether T depends on `q` (false for Cartesian coordinates of free particles).
    fn depends_on_position(&self) -> bool {
        true
    }

    /// Whether M = ∂²T/∂q̇² is one constant matrix for all (t, q, q̇). It is then computed and
    /// factored once.
    fn constant_mass_matrix(&self) -> bool {
        false
    }

    /// The number of coordinates, when every value of the type has the same (a double
    /// pendulum's 2; `None`, the default, for a chain of any length). The derivative passes are
    /// then compiled for that one size only, which makes the code built for the type about four
    /// times smaller (the build is faster); a wrong value costs speed, never correctness.
    const FIXED_DOF: Option<usize> = None;
}

impl<K: KineticEnergy + ?Sized> KineticEnergy for &K {
    const FIXED_DOF: Option<usize> = K::FIXED_DOF;
    #[inline]
    fn kinetic<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        (**self).kinetic(t, q, qd)
    }
    fn depends_on_time(&self) -> bool {
        (**self).depends_on_time()
    }
    fn depends_on_position(&self) -> bool {
        (**self).depends_on_position()
    }
    fn constant_mass_matrix(&self) -> bool {
        (**self).constant_mass_matrix()
    }
}
