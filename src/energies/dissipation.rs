//! Rayleigh's dissipation function Φ(t, q, q̇).

use crate::scalar::Scalar;

/// Rayleigh's dissipation function Φ(t, q, q̇) (seed eq. 54): the viscous generalized force is
/// −∂Φ/∂q̇ (eq. 55), and 2Φ is the power dissipated when Φ is quadratic in q̇.
///
/// `()` is the absent dissipation: it is never called and costs no derivative pass.
pub trait Dissipation {
    /// Φ at time `t`, coordinates `q` and velocities `qd`.
    fn dissipation<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D;

    /// Whether this part exists; `false` only for the absent `()`.
    fn is_present(&self) -> bool {
        true
    }
}

impl Dissipation for () {
    #[inline]
    fn dissipation<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D]) -> D {
        D::zero()
    }
    fn is_present(&self) -> bool {
        false
    }
}

impl<R: Dissipation + ?Sized> Dissipation for &R {
    #[inline]
    fn dissipation<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        (**self).dissipation(t, q, qd)
    }
    fn is_present(&self) -> bool {
        (**self).is_present()
    }
}

/// Two dissipation functions add.
impl<A: Dissipation, B: Dissipation> Dissipation for (A, B) {
    #[inline]
    fn dissipation<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        match (self.0.is_present(), self.1.is_present()) {
            (true, true) => self.0.dissipation(t, q, qd) + self.1.dissipation(t, q, qd),
            (true, false) => self.0.dissipation(t, q, qd),
            (false, true) => self.1.dissipation(t, q, qd),
            (false, false) => D::zero(),
        }
    }
    fn is_present(&self) -> bool {
        self.0.is_present() || self.1.is_present()
    }
}
