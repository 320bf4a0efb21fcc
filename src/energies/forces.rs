//! Generalized forces Q(t, q, q̇) that no potential describes.

use crate::scalar::Scalar;

/// Non-conservative generalized forces Q″(t, q, q̇) (seed eq. 4, 55): forcing, friction, follower
/// loads, anything whose virtual work Σ Qᵢ δqᵢ is not −δU.
///
/// `()` is the absent force: it is never called.
pub trait GeneralizedForces {
    /// Add Q(t, q, q̇) into `out` (length = number of coordinates; it arrives zeroed or holding
    /// other contributions, so add rather than overwrite).
    fn forces<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]);

    /// Whether Q depends on `t` explicitly (a driving force).
    fn depends_on_time(&self) -> bool {
        true
    }

    /// Whether this part exists; `false` only for the absent `()`.
    fn is_present(&self) -> bool {
        true
    }
}

impl GeneralizedForces for () {
    #[inline]
    fn forces<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], _out: &mut [D]) {}
    fn depends_on_time(&self) -> bool {
        false
    }
    fn is_present(&self) -> bool {
        false
    }
}

impl<Q: GeneralizedForces + ?Sized> GeneralizedForces for &Q {
    #[inline]
    fn forces<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        (**self).forces(t, q, qd, out)
    }
    fn depends_on_time(&self) -> bool {
        (**self).depends_on_time()
    }
    fn is_present(&self) -> bool {
        (**self).is_present()
    }
}

/// Two sets of generalized forces add.
impl<A: GeneralizedForces, B: GeneralizedForces> GeneralizedForces for (A, B) {
    #[inline]
    fn forces<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        if self.0.is_present() {
            self.0.forces(t, q, qd, out);
        }
        if self.1.is_present() {
            self.1.forces(t, q, qd, out);
        }
    }
    fn depends_on_time(&self) -> bool {
        self.0.depends_on_time() || self.1.depends_on_time()
    }
    fn is_present(&self) -> bool {
        self.0.is_present() || self.1.is_present()
    }
}
