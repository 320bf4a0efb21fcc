//! Potential energy U(t, q).

use crate::scalar::Scalar;

/// The potential energy U(t, q) of the conservative forces (seed eq. 3): Q = −∂U/∂q.
///
/// `()` is the absent potential: it is never called and costs no derivative pass.
pub trait Potential {
    /// U at time `t` and coordinates `q`.
    fn potential<D: Scalar>(&self, t: D, q: &[D]) -> D;

    /// Whether U depends on `t` explicitly.
    fn depends_on_time(&self) -> bool {
        true
    }

    /// Whether this part exists; `false` only for the absent `()`.
    fn is_present(&self) -> bool {
        true
    }
}

impl Potential for () {
    #[inline]
    fn potential<D: Scalar>(&self, _t: D, _q: &[D]) -> D {
        D::zero()
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn is_present(&self) -> bool {
        false
    }
}

impl<P: Potential + ?Sized> Potential for &P {
    #[inline]
    fn potential<D: Scalar>(&self, t: D, q: &[D]) -> D {
        (**self).potential(t, q)
    }
    fn depends_on_time(&self) -> bool {
        (**self).depends_on_time()
    }
    fn is_present(&self) -> bool {
        (**self).is_present()
    }
}

/// Two potentials add.
impl<A: Potential, B: Potential> Potential for (A, B) {
    #[inline]
    fn potential<D: Scalar>(&self, t: D, q: &[D]) -> D {
        match (self.0.is_present(), self.1.is_present()) {
            (true, true) => self.0.potential(t, q) + self.1.potential(t, q),
            (true, false) => self.0.potential(t, q),
            (false, true) => self.1.potential(t, q),
            (false, false) => D::zero(),
        }
    }
    fn depends_on_time(&self) -> bool {
        self.0.depends_on_time() || self.1.depends_on_time()
    }
    fn is_present(&self) -> bool {
        self.0.is_present() || self.1.is_present()
    }
}
