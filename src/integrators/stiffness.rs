//! How stiff a system is at its initial state, from the eigenvalues of the AD Jacobian of the
//! first-order system ẏ = (q̇, q̈): the time scales [`Method::Auto`](super::Method::Auto) chooses
//! by and the modes the stability check of fixed-step explicit methods tests.

use crate::dynamics::Dynamics;
use nalgebra::{Complex, DMatrix};
use num_dual::Dual64;

/// Larger systems are not tested for stiffness (the eigenvalues of a 2n × 2n Jacobian).
const STIFFNESS_MAX_DOF: usize = 64;

/// A ratio of time scales at or above this counts as stiff.
pub(crate) const STIFFNESS_RATIO: f64 = 1e3;

/// The time scales of the linearised first-order system at the initial state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct StiffnessEstimate {
    /// The largest |λ| of J = ∂(q̇, q̈)/∂(q, q̇).
    pub(crate) fastest: f64,
    /// The largest |λ| an integrator must resolve for accuracy: of the oscillatory
    /// (|Im λ| > |Re λ|) and the growing (Re λ > 0) modes, and at least 1/|span|.
    pub(crate) resolved: f64,
}

impl StiffnessEstimate {
    /// How much faster the fastest mode is than those that must be resolved.
    pub(crate) fn ratio(&self) -> f64 {
        self.fastest / self.resolved
    }

    /// Stiff: a decaying mode at least [`STIFFNESS_RATIO`] times faster than everything the
    /// solution must follow, so an explicit method's step is set by stability.
    pub(crate) fn stiff(&self) -> bool {
        self.ratio() >= STIFFNESS_RATIO
    }
}

/// Estimate the time scales at (t₀, q₀, q̇₀) from the eigenvalues of the AD Jacobian of the
/// first-order system (2n dual evaluations of the accelerations and one Schur decomposition):
/// stiffness means fast decaying (relaxation) modes next to slow ones. Fast oscillatory modes
/// are not stiffness in this sense — an L-stable method would damp them — and neither are
/// growing ones. `None` for more than 64 coordinates or when the Jacobian cannot be formed.
pub(crate) fn estimate_stiffness<S: Dynamics + ?Sized>(
    system: &S,
    t0: f64,
    q0: &[f64],
    qd0: &[f64],
    span: f64,
) -> Option<StiffnessEstimate> {
    let eig = jacobian_spectrum(system, t0, q0, qd0)?;
    let fastest = eig.iter().fold(0.0_f64, |m, l| m.max(l.norm()));
    let resolved = eig
        .iter()
        .filter(|l| l.im.abs() > l.re.abs() || l.re > 0.0)
        .fold(1.0 / span.abs(), |m, l| m.max(l.norm()));
    Some(StiffnessEstimate { fastest, resolved })
}

/// The eigenvalues of the AD Jacobian J = ∂(q̇, q̈)/∂(q, q̇) of the first-order system at
/// (t₀, q₀, q̇₀): 2n dual evaluations of the accelerations and one Schur decomposition. `None`
/// for more than 64 coordinates or when the Jacobian cannot be formed.
pub(crate) fn jacobian_spectrum<S: Dynamics + ?Sized>(
    system: &S,
    t0: f64,
    q0: &[f64],
    qd0: &[f64],
) -> Option<Vec<Complex<f64>>> {
    let n = q0.len();
    if n > STIFFNESS_MAX_DOF {
        return None;
    }
    let mut y = q0.to_vec();
    y.extend_from_slice(qd0);
    let zero = Dual64::from_re(0.0);
    let (mut xd, mut fd) = (vec![zero; 2 * n], vec![zero; n]);
    let mut lower = DMatrix::zeros(n, 2 * n);
    crate::dynamics::acceleration_jacobian(system, t0, &y, &mut xd, &mut fd, &mut lower).ok()?;
    let mut j = DMatrix::zeros(2 * n, 2 * n);
    for i in 0..n {
        j[(i, n + i)] = 1.0;
        for k in 0..2 * n {
            j[(n + i, k)] = lower[(i, k)];
        }
    }
    if !j.iter().all(|x| x.is_finite()) {
        return None;
    }
    Some(
        j.try_schur(1e-14, 10_000)?
            .complex_eigenvalues()
            .iter()
            .copied()
            .collect(),
    )
}
