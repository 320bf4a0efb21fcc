//! Constraints stated as equations: holonomic g(t, q) = 0 and velocity constraints
//! a(t, q)·q̇ + b(t, q) = 0.

use crate::scalar::Scalar;

/// Constraints on the motion (seed §2: N particles under f constraints; §3.1–3.2: the constraint
/// forces R do no work in a virtual displacement): `holonomic_count` holonomic rows
/// g(t, q) = 0 and `velocity_count` velocity rows a(t, q)·q̇ + b(t, q) = 0, the latter linear in
/// q̇ (nonholonomic constraints, such as rolling without slipping, which no choice of
/// coordinates eliminates).
///
/// Rows are numbered holonomic first, then velocity: row `i < holonomic_count()` is gᵢ, row
/// `holonomic_count() + j` is the j-th velocity constraint. [`crate::Constrained`] adds them to
/// any [`Dynamics`](crate::Dynamics) through Lagrange's multipliers (Lagrange's equations of the
/// first kind, eq. 55 with M q̈ = f + Gᵀλ).
///
/// Both parts default to absent (a count of zero), so a set of only holonomic constraints
/// implements `holonomic_count` and `holonomic` alone. `()` is the absent set.
///
/// ```
/// use lagrangian::{Constraints, Scalar};
///
/// /// A rod of length `l` from the origin: x² + y² − l² = 0.
/// struct Rod {
///     l: f64,
/// }
///
/// impl Constraints for Rod {
///     fn holonomic_count(&self) -> usize {
///         1
///     }
///     fn holonomic<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
///         out[0] = q[0] * q[0] + q[1] * q[1] - self.l * self.l;
///     }
///     fn depends_on_time(&self) -> bool {
///         false
///     }
///     fn name(&self, _row: usize) -> String {
///         "rod".into()
///     }
/// }
///
/// let mut g = [0.0];
/// Rod { l: 2.0 }.holonomic(0.0, &[0.0, -2.0], &mut g);
/// assert_eq!(g[0], 0.0);
/// ```
pub trait Constraints {
    /// Number of holonomic rows g(t, q) = 0.
    fn holonomic_count(&self) -> usize {
        0
    }

    /// Write g(t, q) to `out` (length [`holonomic_count`](Self::holonomic_count); overwrite it).
    fn holonomic<D: Scalar>(&self, _t: D, _q: &[D], _out: &mut [D]) {}

    /// Number of velocity rows a(t, q)·q̇ + b(t, q) = 0.
    fn velocity_count(&self) -> usize {
        0
    }

    /// Write a(t, q)·q̇ + b(t, q) to `out` (length [`velocity_count`](Self::velocity_count);
    /// overwrite it). It must be linear in q̇: [`crate::Constrained`] refuses a row whose second
    /// derivative in q̇ is not zero ([`Error::NonlinearVelocityConstraint`](crate::Error)).
    fn velocity<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], _out: &mut [D]) {}

    /// Whether any row depends on `t` explicitly (a moving, rheonomic constraint). `false` lets
    /// the derivative passes hold t constant, so a row that does read t must keep the default.
    fn depends_on_time(&self) -> bool {
        true
    }

    /// Whether this part exists; `false` only for the absent `()`.
    fn is_present(&self) -> bool {
        self.holonomic_count() + self.velocity_count() > 0
    }

    /// The name of row `row` (holonomic rows first), for messages.
    fn name(&self, row: usize) -> String {
        format!("constraint {row}")
    }

    /// G (row-major, rows × n: ∂g/∂q, then the velocity rows' ∂/∂q̇) into `g` and γ into `gamma`
    /// at an `f64` state from derivatives taken ahead of time (the expression route derives them
    /// on its graph and compiles them), returning `true`; the default `false` lets
    /// [`crate::Constrained`] take them by dual numbers at each evaluation.
    fn compiled_rows(
        &self,
        _t: f64,
        _q: &[f64],
        _qd: &[f64],
        _g: &mut [f64],
        _gamma: &mut [f64],
    ) -> bool {
        false
    }
}

impl Constraints for () {
    fn depends_on_time(&self) -> bool {
        false
    }
    fn is_present(&self) -> bool {
        false
    }
}

impl<C: Constraints + ?Sized> Constraints for &C {
    fn holonomic_count(&self) -> usize {
        (**self).holonomic_count()
    }
    #[inline]
    fn holonomic<D: Scalar>(&self, t: D, q: &[D], out: &mut [D]) {
        (**self).holonomic(t, q, out)
    }
    fn velocity_count(&self) -> usize {
        (**self).velocity_count()
    }
    #[inline]
    fn velocity<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        (**self).velocity(t, q, qd, out)
    }
    fn depends_on_time(&self) -> bool {
        (**self).depends_on_time()
    }
    fn is_present(&self) -> bool {
        (**self).is_present()
    }
    fn name(&self, row: usize) -> String {
        (**self).name(row)
    }
    #[inline]
    fn compiled_rows(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        g: &mut [f64],
        gamma: &mut [f64],
    ) -> bool {
        (**self).compiled_rows(t, q, qd, g, gamma)
    }
}
