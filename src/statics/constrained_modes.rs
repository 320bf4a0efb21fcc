//! Small oscillations on the constraint manifold: the modes of a constrained equilibrium.
//!
//! About an equilibrium (q*, λ) of a [`Constrained`] system (r(q*) = Gᵀλ, g(t, q*) = 0; see
//! [`crate::constrained_equilibrium`]) the motions that keep g = 0 to first order are
//! δq = Z η, Z an orthonormal basis of null(G), and Lagrange's equations of the first kind
//! linearize to
//!
//! Zᵀ M Z η̈ + Zᵀ H Z η = 0,    H = K − Σᵢ λᵢ ∂²gᵢ/∂q²,
//!
//! the constraints' curvature weighted by the reactions entering the stiffness (a pendulum in
//! Cartesian coordinates has K = 0: its restoring stiffness is all −λ ∂²g/∂q²).

use super::constrained::{Augmented, check_rank, null_basis};
use super::linearize::{
    EQUILIBRIUM_TOLERANCE, ModeProblem, Modes, STABILITY_TOLERANCE, UNDAMPED_TOLERANCE,
    largest_positive, linearize, pair_of, sorted, symmetric_modes,
};
use super::residual::StaticProblem;
use super::stability::Stability;
use crate::checks::check_state;
use crate::constrained::Constrained;
use crate::dynamics::Dynamics;
use crate::energies::Constraints;
use crate::error::{Error, Result};
use crate::nonlinear::Residual;
use nalgebra::{Complex, DMatrix, DVector};

/// The modes of small oscillation of a constrained conservative system about an equilibrium
/// (q, λ) on its holonomic manifold, at the instant t (q̇ = 0): n − k modes for n coordinates
/// and k holonomic rows.
///
/// With G = ∂g/∂q (k × n, full rank), Z (n × (n − k)) an orthonormal basis of null(G) (the last
/// right singular vectors of G), M the wrapped system's mass matrix at q̇ = 0 and
/// H = K − Σᵢ λᵢ ∂²gᵢ/∂q² the Hessian of the balance (K = ∂r/∂q the static stiffness, the
/// curvature of the constraints by hyper-duals; as [`crate::ConstrainedEquilibrium::hessian`]),
/// the motions δq = Z η that keep g = 0 to first order obey the reduced symmetric generalized
/// eigenproblem
///
/// Zᵀ H Z v = ω² Zᵀ M Z v,
///
/// solved as [`crate::modes`] solves K φ = ω² M φ (Cholesky of Zᵀ M Z, then a symmetric
/// eigenproblem). The shapes are returned in the full coordinates, φ = Z v, normalized to
/// φᵀ M φ = 1 with the largest entry positive, so G φ = 0. Convention of [`Modes`]: ascending by
/// √|ω²|; ω² < 0 is a divergence on the manifold (eigenvalues ±√(−ω²), verdict unstable); a zero
/// ω² is neutral; all ω² > 0 stable. `problem` is [`ModeProblem::Undamped`], `eigenvalues` the
/// 2(n − k) values ±iω (±√(−ω²)), `damping_ratios` zero, and `linearization` that of the wrapped
/// (unconstrained) system at (q, q̇ = 0), whose M the reduction uses. λ is the multiplier of
/// [`crate::constrained_equilibrium`] (sign convention of [`Constrained`]: r = Gᵀλ); pass its `q`
/// and `multipliers`. Velocity rows are ignored, as there. The constraints and forces are taken
/// at t (frozen).
///
/// # Errors
/// [`Error::DimensionMismatch`] when q is not of length n or λ not of length k;
/// [`Error::NonFinite`] for non-finite t, q or λ or a non-finite model;
/// [`Error::DependentConstraints`] when G is rank-deficient at q; [`Error::SingularMassMatrix`]
/// when M (or Zᵀ M Z) is not positive definite; [`Error::InvalidInput`] when (q, λ) is not an
/// equilibrium on the manifold (g ≠ 0 or r ≠ Gᵀλ), or when the system has damping, gyroscopic
/// or circulatory terms (not conservative: use [`crate::linearize`]). Without holonomic rows this
/// is [`crate::modes`].
///
/// A unit mass on a rod of length 1 under gravity 9.81, in Cartesian coordinates: one mode,
/// ω² = g/l, moving sideways.
///
/// ```
/// use lagrangian::{Constrained, Constraints, KineticEnergy, Potential, Scalar, Stability};
/// use lagrangian::{StaticsOptions, System, constrained_equilibrium, constrained_modes};
///
/// struct Point;
/// impl KineticEnergy for Point {
///     fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
///         (qd[0] * qd[0] + qd[1] * qd[1]) * 0.5
///     }
/// }
/// struct Gravity;
/// impl Potential for Gravity {
///     fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
///         q[1] * 9.81
///     }
/// }
/// struct Rod;
/// impl Constraints for Rod {
///     fn holonomic_count(&self) -> usize {
///         1
///     }
///     fn holonomic<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
///         out[0] = q[0] * q[0] + q[1] * q[1] - 1.0;
///     }
///     fn depends_on_time(&self) -> bool {
///         false
///     }
/// }
///
/// let pendulum = Constrained::new(System::new(2, Point).with_potential(Gravity), Rod);
/// let e = constrained_equilibrium(&pendulum, 0.0, &[0.3, -0.8], &StaticsOptions::default())?;
/// let found = constrained_modes(&pendulum, 0.0, e.q.as_slice(), e.multipliers.as_slice())?;
/// assert_eq!(found.frequencies.len(), 1);
/// assert!((found.omega_squared[0] - 9.81).abs() < 1e-12);
/// assert!((found.shapes[(0, 0)].re - 1.0).abs() < 1e-12 && found.shapes[(1, 0)].norm() < 1e-12);
/// assert_eq!(found.stability, Stability::Stable);
/// # Ok::<(), lagrangian::Error>(())
/// ```
pub fn constrained_modes<S: Dynamics, C: Constraints>(
    system: &Constrained<S, C>,
    t: f64,
    q: &[f64],
    lambda: &[f64],
) -> Result<Modes> {
    let inner = system.system();
    let constraints = system.constraints();
    let n = inner.dof();
    let k = if constraints.is_present() {
        constraints.holonomic_count()
    } else {
        0
    };
    check_state(n, t, q, None)?;
    if lambda.len() != k {
        return Err(Error::DimensionMismatch {
            what: "lambda",
            expected: k,
            got: lambda.len(),
        });
    }
    if lambda.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite { what: "lambda", t });
    }
    if k == 0 {
        return super::modes(inner, t, q);
    }
    let mut problem = Augmented {
        statics: StaticProblem::new(inner, t),
        constraints,
        t,
        n,
        k,
    };
    let g = problem.jacobian_g(q)?;
    check_rank(&g, constraints, t, q)?;
    let hessian = problem.statics.jacobian(q)? - problem.curvature(q, lambda);
    if hessian.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            what: "Hessian K − Σλᵢ∂²gᵢ/∂q²",
            t,
        });
    }
    let z_state: Vec<f64> = q.iter().chain(lambda).copied().collect();
    let (f, scale) = problem.residual(&z_state)?;
    let reach = hessian.norm() * (1.0 + q.iter().fold(0.0_f64, |m, x| x.abs().max(m)));
    if f.norm() > EQUILIBRIUM_TOLERANCE * (scale + reach) {
        return Err(Error::InvalidInput {
            what: "q, lambda",
            why: format!(
                "({q:?}, {lambda:?}) is not an equilibrium on the constraint manifold at t = {t}: \
                 [r − Gᵀλ; g] leaves {:e} (of loads {scale:e}); find one with \
                 constrained_equilibrium()",
                f.norm()
            ),
        });
    }
    let lin = linearize(inner, t, q, &vec![0.0; n])?;
    let m = &lin.m;
    let z = null_basis(&g);
    let reduced_h = z.transpose() * &hessian * &z;
    let reduced_m = z.transpose() * m * &z;
    let h_scale = reduced_h.amax();
    if lin.c.amax() > UNDAMPED_TOLERANCE * (m.amax() * h_scale.max(hessian.amax())).sqrt()
        || (&reduced_h - reduced_h.transpose()).amax() > UNDAMPED_TOLERANCE * h_scale
    {
        return Err(Error::InvalidInput {
            what: "system",
            why: "damping, gyroscopic or circulatory terms: constrained_modes solves the \
                  conservative problem Zᵀ H Z v = ω² Zᵀ M Z v only"
                .to_string(),
        });
    }
    let Some((omega2, reduced_shapes)) = symmetric_modes(&reduced_m, &reduced_h) else {
        return Err(Error::SingularMassMatrix {
            t,
            q: q.to_vec(),
            reason: "not positive definite",
        });
    };
    let r = n - k;
    let mut order: Vec<usize> = (0..r).collect();
    order.sort_by(|&i, &j| omega2[i].abs().total_cmp(&omega2[j].abs()));
    let omega_squared = DVector::from_iterator(r, order.iter().map(|&i| omega2[i]));
    if omega_squared.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            what: "reduced eigenvalues ω²",
            t,
        });
    }
    let frequencies = omega_squared.map(|w2| w2.abs().sqrt());
    let mut shapes = DMatrix::zeros(n, r);
    for (col, &i) in order.iter().enumerate() {
        let mut phi = &z * reduced_shapes.column(i);
        largest_positive(&mut phi);
        shapes.set_column(col, &phi.map(|x| Complex::new(x, 0.0)));
    }
    let eigenvalues = sorted(omega_squared.iter().flat_map(|&w2| pair_of(w2)).collect());
    let (stability, reason) = verdict(&omega_squared);
    Ok(Modes {
        problem: ModeProblem::Undamped,
        frequencies,
        omega_squared,
        damping_ratios: DVector::zeros(r),
        shapes,
        eigenvalues,
        stability,
        reason,
        linearization: lin,
    })
}

/// The verdict of the reduced ω², with the wording of [`crate::modes`].
fn verdict(omega_squared: &DVector<f64>) -> (Stability, String) {
    let tol = STABILITY_TOLERANCE;
    let scale = omega_squared.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
    let on = "on the constraint manifold";
    if omega_squared.is_empty() {
        return (
            Stability::Stable,
            "the constraints fix the configuration (G has full rank n: no virtual displacement)"
                .to_string(),
        );
    }
    if scale == 0.0 {
        return (
            Stability::Neutral,
            format!("every ω² is zero {on}: higher-order terms decide"),
        );
    }
    if let Some(&w2) = omega_squared.iter().find(|&&w2| w2 < -tol * scale) {
        return (
            Stability::Unstable,
            format!(
                "unstable: the real eigenvalue λ = {:.6e} > 0: a divergence {on} (ω² = {w2:.6e})",
                (-w2).sqrt()
            ),
        );
    }
    if omega_squared.iter().all(|&w2| w2 > tol * scale) {
        return (
            Stability::Stable,
            format!(
                "the reduced Hessian Zᵀ H Z is positive definite (a strict minimum of U − λ·g \
                 {on}): stable, with undamped oscillations on the imaginary axis"
            ),
        );
    }
    (
        Stability::Neutral,
        format!("a zero ω² {on} (Zᵀ H Z is singular): higher-order terms decide"),
    )
}
