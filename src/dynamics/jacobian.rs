//! Jacobians by forward-mode AD: the system's generic `*_into` methods evaluated on [`Dual64`],
//! one direction per column — no finite differences. Used by the implicit integrators, the
//! stiffness and stability tests, the linearization and the compiled models' checks.

use super::Dynamics;
use crate::error::Result;
use nalgebra::DMatrix;
use num_dual::Dual64;

/// `jac[(i, j)] = ∂fᵢ/∂xⱼ` at `x` by forward mode: column j from one evaluation of `f` on
/// [`Dual64`] seeded in xⱼ. `xd` (length of x) and `fd` (length of f) are work space.
pub(crate) fn jacobian(
    x: &[f64],
    xd: &mut [Dual64],
    fd: &mut [Dual64],
    jac: &mut DMatrix<f64>,
    mut f: impl FnMut(&[Dual64], &mut [Dual64]) -> Result<()>,
) -> Result<()> {
    for (d, &v) in xd.iter_mut().zip(x) {
        *d = Dual64::from_re(v);
    }
    for j in 0..x.len() {
        xd[j].eps = 1.0;
        let r = f(xd, fd);
        xd[j].eps = 0.0;
        r?;
        for (i, y) in fd.iter().enumerate() {
            jac[(i, j)] = y.eps;
        }
    }
    Ok(())
}

/// ∂a/∂(q, q̇) at (t, q, q̇), the lower half of the Jacobian of the first-order system
/// y = (q, q̇), ẏ = (q̇, a): `jac` is n × 2n. `xd` has length 2n, `fd` length n. From the
/// machine code of the system's derived program when it has one, otherwise (and when that
/// code's checks fail, so that the error is the accelerations' own) by dual numbers.
pub(crate) fn acceleration_jacobian<S: Dynamics + ?Sized>(
    system: &S,
    t: f64,
    y: &[f64],
    xd: &mut [Dual64],
    fd: &mut [Dual64],
    jac: &mut DMatrix<f64>,
) -> Result<()> {
    let n = y.len() / 2;
    if let Some(program) = system.derived_program()
        && program.acceleration_jacobian(t, &y[..n], &y[n..], jac.as_mut_slice())
    {
        return Ok(());
    }
    let td = Dual64::from_re(t);
    jacobian(y, xd, fd, jac, |x, out| {
        system.accelerations_into(td, &x[..n], &x[n..], out)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::ComplexField;

    #[test]
    fn jacobian_matches_hand_derivative() {
        // f(x, y) = (x² y, sin x + y³).
        let x = [0.7, -1.3];
        let mut xd = [Dual64::from_re(0.0); 2];
        let mut fd = [Dual64::from_re(0.0); 2];
        let mut jac = DMatrix::zeros(2, 2);
        jacobian(&x, &mut xd, &mut fd, &mut jac, |x, f| {
            f[0] = x[0] * x[0] * x[1];
            f[1] = x[0].sin() + x[1].powi(3);
            Ok(())
        })
        .unwrap();
        assert_relative_eq!(jac[(0, 0)], 2.0 * x[0] * x[1], epsilon = 1e-15);
        assert_relative_eq!(jac[(0, 1)], x[0] * x[0], epsilon = 1e-15);
        assert_relative_eq!(jac[(1, 0)], x[0].cos(), epsilon = 1e-15);
        assert_relative_eq!(jac[(1, 1)], 3.0 * x[1] * x[1], epsilon = 1e-15);
    }
}
