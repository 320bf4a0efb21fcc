//! Small motions: the equations of motion linearized about a state, and the modes of an
//! equilibrium.
//!
//! About any state (q₀, q̇₀) at time t the equations of motion q̈ = a(t, q, q̇) (eq. 55) read, to
//! first order in δq = q − q₀ and δq̇ = q̇ − q̇₀,
//!
//! M (q̈ − a₀) + C δq̇ + K δq = 0   with   C = −M ∂a/∂q̇,  K = −M ∂a/∂q,  a₀ = a(t, q₀, q̇₀),
//!
//! or δẋ = A δx (plus the constant (q̇₀, a₀)) for x = (q, q̇), A = [[0, I], [∂a/∂q, ∂a/∂q̇]]. The
//! Jacobian of a is
//! exact — dual numbers through the system's own code
//! ([`crate::dynamics`]' `acceleration_jacobian`) — at rest or moving, so no q̇-terms are left
//! behind away from rest. At an equilibrium (a₀ = 0, q̇₀ = 0) M ∂a = ∂f for the force side f of
//! eq. 55, so C = −∂f/∂q̇ is the Rayleigh damping ∂²Φ/∂q̇² plus the gyroscopic terms of the part
//! of T linear in q̇ (and −∂Q″/∂q̇), and K = −∂f/∂q the stiffness, centrifugal part included:
//! the [`crate::static_stiffness`] there.
//!
//! The modes of an equilibrium: where C vanishes and K is symmetric, the undamped problem
//! K φ = ω² M φ (Cholesky of M, then a symmetric eigenproblem: real ω², mass-normalized real
//! shapes); otherwise — damping, gyroscopic or circulatory terms — the eigenvalues of A (via
//! its Schur form), in conjugate pairs λ, λ̄ or real pairs, each pair one mode with
//! λ² + 2ζω λ + ω² = 0. Stability follows from the eigenvalues, with the reason stated.

use crate::checks::{check_state, finite};
use crate::dynamics::{Dynamics, acceleration_jacobian};
use crate::error::{Error, Result};
use crate::statics::{Stability, classify, static_residual, static_stiffness_of};
use nalgebra::{Cholesky, Complex, DMatrix, DVector, Schur, SymmetricEigen};
use num_dual::Dual64;

/// λ with |λ|² below this fraction of max |λ|² count as zero (ω² or K relative to the largest,
/// as the statics' energy criterion counts K's eigenvalues), real parts beyond it times max |λ|
/// as positive or negative (the default of [`crate::StaticsOptions::stability_tolerance`]).
pub(crate) const STABILITY_TOLERANCE: f64 = 1e-9;

/// C (relative to √(|M| |K|)) and the antisymmetric part of K (relative to |K|) below this are
/// round-off: the undamped problem K φ = ω² M φ applies.
pub(crate) const UNDAMPED_TOLERANCE: f64 = 1e-12;

/// A q at which |r| exceeds this fraction of the load scale is not an equilibrium.
pub(crate) const EQUILIBRIUM_TOLERANCE: f64 = 1e-8;

/// The equations of motion linearized about a state, from [`linearize`].
#[derive(Debug, Clone, PartialEq)]
pub struct Linearization {
    /// Time of the operating point.
    pub t: f64,
    /// Configuration of the operating point.
    pub q: DVector<f64>,
    /// Velocities of the operating point.
    pub qd: DVector<f64>,
    /// Accelerations a₀ at the operating point (zero at an equilibrium).
    pub accelerations: DVector<f64>,
    /// Mass matrix M = ∂²T/∂q̇².
    pub m: DMatrix<f64>,
    /// C = −M ∂q̈/∂q̇: damping, gyroscopic and Coriolis terms.
    pub c: DMatrix<f64>,
    /// K = −M ∂q̈/∂q: stiffness, centrifugal part included.
    pub k: DMatrix<f64>,
    /// State matrix ∂ẋ/∂x of x = (q, q̇), 2n × 2n: [[0, I], [∂q̈/∂q, ∂q̈/∂q̇]].
    pub a: DMatrix<f64>,
    /// Eigenvalues of `a`, by magnitude then imaginary part.
    pub eigenvalues: DVector<Complex<f64>>,
}

/// How [`Modes`] were found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModeProblem {
    /// C = 0 and K symmetric: K φ = ω² M φ, real ω² and real mass-normalized shapes.
    Undamped,
    /// Damping, gyroscopic or circulatory terms: the eigenvalues and eigenvectors of A.
    StateSpace,
}

/// The modes of small motion about an equilibrium, from [`modes`].
///
/// Each mode is a pair of eigenvalues λ₁, λ₂ of A — a complex pair λ, λ̄, or two real ones —
/// with characteristic polynomial λ² + 2ζω λ + ω² (ω² = λ₁λ₂, 2ζω = −(λ₁ + λ₂)); there are n of
/// them. ω² < 0 is a divergence (λ = ±√(−ω²)), not an oscillation.
#[derive(Debug, Clone, PartialEq)]
pub struct Modes {
    /// How they were found.
    pub problem: ModeProblem,
    /// Natural frequencies √|ω²| in rad/s, ascending (the undamped frequency of a damped mode,
    /// |λ|; the growth rate of a divergence).
    pub frequencies: DVector<f64>,
    /// ω² of each mode, in the order of `frequencies`: the eigenvalues of K φ = ω² M φ in the
    /// undamped case; negative for a divergence.
    pub omega_squared: DVector<f64>,
    /// Damping ratios ζ = −(λ₁ + λ₂)/(2ω): 0 undamped, in (0, 1) underdamped (damped frequency
    /// ω √(1 − ζ²)), ≥ 1 overdamped, negative growing; ±∞ for ω = 0 with damping.
    pub damping_ratios: DVector<f64>,
    /// Mode shapes as columns, normalized to φᴴ M φ = 1 (real in the undamped case; the q-part
    /// of A's eigenvector for λ with Im λ ≥ 0, its largest entry made real, otherwise).
    pub shapes: DMatrix<Complex<f64>>,
    /// All 2n eigenvalues of A, by magnitude then imaginary part.
    pub eigenvalues: DVector<Complex<f64>>,
    /// The stability of the equilibrium these eigenvalues imply.
    pub stability: Stability,
    /// Why, in words.
    pub reason: String,
    /// The linearization at (q, q̇ = 0).
    pub linearization: Linearization,
}

/// The equations of motion linearized about (t, q, q̇): M, C, K and the state matrix A of
/// x = (q, q̇), exact by dual numbers at any state (not only at an equilibrium).
///
/// Fails with [`Error::DimensionMismatch`] or [`Error::NonFinite`] for a bad state,
/// [`Error::SingularMassMatrix`] where M cannot be inverted, [`Error::NonFinite`] when the
/// model gives non-finite values there, and [`Error::NoConvergence`] if the eigenvalues of A are
/// not found.
///
/// The seed's two masses and two springs (eq. 41–44): A's eigenvalues are ±iω of the two
/// natural frequencies, where the forced response resonates.
///
/// ```
/// use lagrangian::linearize;
/// use lagrangian::scenes::ForcedTwoMass;
/// # use approx::assert_relative_eq;
/// let (m1, m2, k1, k2) = (1.0, 2.0, 30.0, 20.0);
/// let scene = ForcedTwoMass::new(m1, m2, k1, k2);
/// let lin = linearize(&scene.system(), 0.0, &[0.0, 0.0], &[0.0, 0.0]).unwrap();
/// assert_relative_eq!(lin.k[(0, 0)], k1 + k2, max_relative = 1e-14);
/// assert_relative_eq!(lin.k[(0, 1)], -k2, max_relative = 1e-14);
/// assert_eq!(lin.a.shape(), (4, 4));
/// ```
pub fn linearize<S: Dynamics + ?Sized>(
    system: &S,
    t: f64,
    q: &[f64],
    qd: &[f64],
) -> Result<Linearization> {
    let n = system.dof();
    check_state(n, t, q, Some(qd))?;
    let accelerations = system.accelerations(t, q, qd)?;
    let m = system.mass_matrix(t, q, qd)?;
    let y: Vec<f64> = q.iter().chain(qd).copied().collect();
    let mut xd = vec![Dual64::from_re(0.0); 2 * n];
    let mut fd = vec![Dual64::from_re(0.0); n];
    let mut lower = DMatrix::zeros(n, 2 * n);
    acceleration_jacobian(system, t, &y, &mut xd, &mut fd, &mut lower)?;
    finite(lower.as_slice(), "Jacobian of the accelerations", t)?;
    let k = -(&m * lower.columns(0, n));
    let c = -(&m * lower.columns(n, n));
    // Finite factors can still overflow in the products.
    finite(k.as_slice(), "stiffness matrix K", t)?;
    finite(c.as_slice(), "damping matrix C", t)?;
    let mut a = DMatrix::zeros(2 * n, 2 * n);
    a.view_mut((0, n), (n, n)).fill_with_identity();
    a.view_mut((n, 0), (n, 2 * n)).copy_from(&lower);
    let eigenvalues = state_eigenvalues(&a, q)?;
    if !eigenvalues
        .iter()
        .all(|z| z.re.is_finite() && z.im.is_finite())
    {
        return Err(Error::NonFinite {
            what: "eigenvalues of A",
            t,
        });
    }
    Ok(Linearization {
        t,
        q: DVector::from_column_slice(q),
        qd: DVector::from_column_slice(qd),
        accelerations,
        m,
        c,
        k,
        a,
        eigenvalues,
    })
}

/// The modes of small oscillation about the equilibrium q at time t (q̇ = 0), and the stability
/// they imply (see [`Modes`]).
///
/// Fails with [`Error::InvalidInput`] when q is not an equilibrium (find one with
/// [`crate::equilibrium`], or use [`linearize`] at any state), and as [`linearize`] does.
///
/// The seed's two masses and two springs (eq. 41–44), m₁ = 1, m₂ = 2, k₁ = 30, k₂ = 20: the
/// forced response resonates at the two natural frequencies, the roots of
/// det(K − ω² M) = 2ω⁴ − 120ω² + 600 = 0.
///
/// ```
/// use lagrangian::{modes, Stability};
/// use lagrangian::scenes::ForcedTwoMass;
/// # use approx::assert_relative_eq;
/// let scene = ForcedTwoMass::new(1.0, 2.0, 30.0, 20.0);
/// let found = modes(&scene.system(), 0.0, &[0.0, 0.0]).unwrap();
/// let root = 600.0_f64.sqrt();
/// assert_relative_eq!(found.frequencies[0], (30.0 - root).sqrt(), max_relative = 1e-13);
/// assert_relative_eq!(found.frequencies[1], (30.0 + root).sqrt(), max_relative = 1e-13);
/// assert_eq!(found.stability, Stability::Stable);
/// // Forced by F cos Ωt, F = (1, 0): the amplitude (K − Ω² M)⁻¹ F grows without bound as Ω
/// // nears ω₁.
/// let lin = &found.linearization;
/// let amplitude = |w: f64| {
///     let f = nalgebra::DVector::from_vec(vec![1.0, 0.0]);
///     (&lin.k - &lin.m * (w * w)).lu().solve(&f).unwrap().norm()
/// };
/// assert!(amplitude(found.frequencies[0] * (1.0 + 1e-6)) > 1e5 * amplitude(0.0));
/// ```
pub fn modes<S: Dynamics + ?Sized>(system: &S, t: f64, q: &[f64]) -> Result<Modes> {
    check_state(system.dof(), t, q, None)?;
    let (r, scale) = static_residual(system, t, q)?;
    // The loads may cancel at the root (sin π of a pendulum on top is 1e-16 of m g l), so the
    // stiffness times the size of q counts too.
    let reach = static_stiffness_of(system, t, q)?.norm()
        * (1.0 + q.iter().fold(0.0, |m, x| x.abs().max(m)));
    if r.norm() > EQUILIBRIUM_TOLERANCE * (scale + reach) {
        return Err(Error::InvalidInput {
            what: "q",
            why: format!(
                "{q:?} is not an equilibrium at t = {t}: the forces at rest leave {:e} unbalanced \
                 (of loads {scale:e}); find one with equilibrium(), or linearize at any state",
                r.norm()
            ),
        });
    }
    modes_unchecked(system, t, q, STABILITY_TOLERANCE)
}

/// [`modes`] without the equilibrium check, with the stability tolerance given.
pub(crate) fn modes_unchecked<S: Dynamics + ?Sized>(
    system: &S,
    t: f64,
    q: &[f64],
    tol: f64,
) -> Result<Modes> {
    let lin = linearize(system, t, q, &vec![0.0; q.len()])?;
    let undamped = undamped_modes(&lin);
    let (problem, pairs, shapes, eigenvalues) = match undamped {
        Some((omega2, shapes)) => {
            let eigenvalues = sorted(omega2.iter().flat_map(|&w2| pair_of(w2)).collect());
            let pairs = omega2.iter().map(|&w2| (w2, 0.0)).collect();
            (ModeProblem::Undamped, pairs, shapes, eigenvalues)
        }
        None => {
            let (pairs, shapes) = state_space_modes(&lin, q)?;
            let eigenvalues = lin.eigenvalues.clone();
            (ModeProblem::StateSpace, pairs, shapes, eigenvalues)
        }
    };
    // Order by frequency √|ω²|.
    let mut order: Vec<usize> = (0..pairs.len()).collect();
    order.sort_by(|&i, &j| pairs[i].0.abs().total_cmp(&pairs[j].0.abs()));
    let omega_squared = DVector::from_iterator(order.len(), order.iter().map(|&i| pairs[i].0));
    let frequencies = omega_squared.map(|w2| w2.abs().sqrt());
    let damping_ratios = DVector::from_iterator(
        order.len(),
        order.iter().map(|&i| {
            let (w2, sum) = pairs[i];
            let w = w2.abs().sqrt();
            if sum == 0.0 {
                0.0
            } else if w > 0.0 {
                -sum / (2.0 * w)
            } else {
                -sum.signum() * f64::INFINITY
            }
        }),
    );
    let shapes = DMatrix::from_fn(q.len(), order.len(), |r, c| shapes[(r, order[c])]);
    let (stability, reason) = verdict(&lin, &eigenvalues, tol);
    Ok(Modes {
        problem,
        frequencies,
        omega_squared,
        damping_ratios,
        shapes,
        eigenvalues,
        stability,
        reason,
        linearization: lin,
    })
}

/// ±iω for ω² ≥ 0, ±√(−ω²) otherwise.
pub(crate) fn pair_of(w2: f64) -> [Complex<f64>; 2] {
    let w = w2.abs().sqrt();
    if w2 >= 0.0 {
        [Complex::new(0.0, -w), Complex::new(0.0, w)]
    } else {
        [Complex::new(-w, 0.0), Complex::new(w, 0.0)]
    }
}

/// Eigenvalues ordered by magnitude, then imaginary part.
pub(crate) fn sorted(mut values: Vec<Complex<f64>>) -> DVector<Complex<f64>> {
    values.sort_by(|a, b| a.norm().total_cmp(&b.norm()).then(a.im.total_cmp(&b.im)));
    DVector::from_vec(values)
}

/// Eigenvalues of A by its real Schur form (a bounded number of sweeps).
fn state_eigenvalues(a: &DMatrix<f64>, q: &[f64]) -> Result<DVector<Complex<f64>>> {
    let max_sweeps = 100 * a.nrows().max(1);
    let Some(schur) = Schur::try_new(a.clone(), f64::EPSILON, max_sweeps) else {
        return Err(Error::NoConvergence {
            iterations: max_sweeps,
            residual: f64::INFINITY,
            q: q.to_vec(),
        });
    };
    Ok(sorted(
        schur.complex_eigenvalues().iter().copied().collect(),
    ))
}

/// ω² ascending and the mass-normalized shapes of K φ = ω² M φ, when C vanishes, K is
/// symmetric and M positive definite.
#[allow(clippy::type_complexity)]
fn undamped_modes(lin: &Linearization) -> Option<(Vec<f64>, DMatrix<Complex<f64>>)> {
    let (m, c, k) = (&lin.m, &lin.c, &lin.k);
    let k_scale = k.amax();
    if c.amax() > UNDAMPED_TOLERANCE * (m.amax() * k_scale).sqrt()
        || (k - k.transpose()).amax() > UNDAMPED_TOLERANCE * k_scale
    {
        return None;
    }
    let (omega2, shapes) = symmetric_modes(m, k)?;
    Some((omega2, shapes.map(|x| Complex::new(x, 0.0))))
}

/// The symmetric generalized eigenproblem K φ = ω² M φ of the symmetric parts of K and M (M
/// positive definite; `None` otherwise): ω² ascending and the shapes as columns, φᵀ M φ = 1,
/// each with its largest entry positive. Cholesky M = L Lᵀ, then the symmetric eigenproblem of
/// L⁻¹ K L⁻ᵀ.
pub(crate) fn symmetric_modes(
    m: &DMatrix<f64>,
    k: &DMatrix<f64>,
) -> Option<(Vec<f64>, DMatrix<f64>)> {
    let l = Cholesky::new((m + m.transpose()) * 0.5)?.l();
    let k_sym = (k + k.transpose()) * 0.5;
    let y = l.solve_lower_triangular(&k_sym)?;
    let s = l.solve_lower_triangular(&y.transpose())?;
    let s = (&s + s.transpose()) * 0.5;
    let n = s.nrows();
    let eig = SymmetricEigen::try_new(s, f64::EPSILON, 100 * n.max(1))?;
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let omega2 = order.iter().map(|&i| eig.eigenvalues[i]).collect();
    let mut shapes = DMatrix::zeros(n, n);
    for (col, &i) in order.iter().enumerate() {
        let mut phi = l.tr_solve_lower_triangular(&eig.eigenvectors.column(i).into_owned())?;
        largest_positive(&mut phi);
        shapes.set_column(col, &phi);
    }
    Some((omega2, shapes))
}

/// Flip a shape so that its largest entry (by magnitude) is positive.
pub(crate) fn largest_positive(phi: &mut DVector<f64>) {
    let big = phi
        .iter()
        .copied()
        .fold(0.0_f64, |b, x| if x.abs() > b.abs() { x } else { b });
    if big < 0.0 {
        *phi = -&*phi;
    }
}

/// The modes from A's eigenvalues: (ω², λ₁ + λ₂) of each pair and the shapes.
#[allow(clippy::type_complexity)]
fn state_space_modes(
    lin: &Linearization,
    q: &[f64],
) -> Result<(Vec<(f64, f64)>, DMatrix<Complex<f64>>)> {
    let values = &lin.eigenvalues;
    let scale = values.iter().fold(0.0_f64, |s, v| s.max(v.norm()));
    let real_cut = UNDAMPED_TOLERANCE.sqrt() * scale;
    // One representative per pair: λ with Im λ > 0 for complex pairs; real eigenvalues sorted
    // and paired outermost first (±σ of a saddle; for several overdamped modes a convention).
    let mut reps: Vec<(Complex<f64>, f64, f64)> = values
        .iter()
        .filter(|v| v.im > real_cut)
        .map(|v| (*v, v.norm_sqr(), 2.0 * v.re))
        .collect();
    let mut real: Vec<f64> = values
        .iter()
        .filter(|v| v.im.abs() <= real_cut)
        .map(|v| v.re)
        .collect();
    real.sort_by(f64::total_cmp);
    while real.len() >= 2 {
        let (lo, hi) = (real.remove(0), real.pop().unwrap_or(0.0));
        reps.push((Complex::new(hi, 0.0), lo * hi, lo + hi));
    }
    let n = q.len();
    let mut shapes = DMatrix::zeros(n, reps.len());
    // Equal representatives (repeated eigenvalues) share one null space: its basis vectors in
    // turn.
    let mut used: Vec<(Complex<f64>, usize)> = Vec::new();
    for (col, (lambda, _, _)) in reps.iter().enumerate() {
        let close = |x: &Complex<f64>| (x - lambda).norm() <= real_cut.max(f64::MIN_POSITIVE);
        let index = match used.iter_mut().find(|(x, _)| close(x)) {
            Some(entry) => {
                entry.1 += 1;
                entry.1
            }
            None => {
                used.push((*lambda, 0));
                0
            }
        };
        let u = eigenvector(lin, *lambda, index, q)?;
        shapes.set_column(col, &u);
    }
    let pairs = reps.iter().map(|&(_, w2, sum)| (w2, sum)).collect();
    Ok((pairs, shapes))
}

/// The q-part u of the `index`-th null vector (u, λu) of A − λI, normalized to uᴴ M u = 1 with
/// its largest entry real and positive.
fn eigenvector(
    lin: &Linearization,
    lambda: Complex<f64>,
    index: usize,
    q: &[f64],
) -> Result<DVector<Complex<f64>>> {
    let n2 = lin.a.nrows();
    let shifted = DMatrix::from_fn(n2, n2, |i, j| {
        Complex::new(lin.a[(i, j)], 0.0)
            - if i == j {
                lambda
            } else {
                Complex::new(0.0, 0.0)
            }
    });
    let max_sweeps = 100 * n2.max(1);
    let Some(svd) = shifted.try_svd_unordered(false, true, f64::EPSILON, max_sweeps) else {
        return Err(Error::NoConvergence {
            iterations: max_sweeps,
            residual: f64::INFINITY,
            q: q.to_vec(),
        });
    };
    let Some(v_t) = svd.v_t else {
        return Err(Error::NonFinite {
            what: "mode shape",
            t: lin.t,
        });
    };
    let mut order: Vec<usize> = (0..n2).collect();
    order.sort_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]));
    let row = order[index.min(n2 - 1)];
    let n = n2 / 2;
    let mut u = DVector::from_fn(n, |i, _| v_t[(row, i)].conj());
    let big = u.iter().copied().fold(Complex::new(0.0, 0.0), |b, x| {
        if x.norm() > b.norm() { x } else { b }
    });
    if big.norm() > 0.0 {
        u *= big.conj() / big.norm();
    }
    let mu = DVector::from_fn(n, |i, _| {
        (0..n)
            .map(|j| Complex::new(lin.m[(i, j)], 0.0) * u[j])
            .sum::<Complex<f64>>()
    });
    let norm2 = u.dotc(&mu).re;
    if norm2 > 0.0 && norm2.is_finite() {
        u /= Complex::new(norm2.sqrt(), 0.0);
    }
    Ok(u)
}

/// The stability that the eigenvalues of A imply, and why.
fn verdict(
    lin: &Linearization,
    eigenvalues: &DVector<Complex<f64>>,
    tol: f64,
) -> (Stability, String) {
    let scale = eigenvalues.iter().fold(0.0_f64, |s, v| s.max(v.norm()));
    if scale == 0.0 {
        return (
            Stability::Neutral,
            "every eigenvalue is zero (nothing restores or moves the system at first order): \
             higher-order terms decide"
                .to_string(),
        );
    }
    // A defective zero eigenvalue is perturbed by √ε in the Schur form, hence the squares.
    let zero = |v: &Complex<f64>| v.norm_sqr() <= tol * scale * scale;
    if let Some(v) = eigenvalues
        .iter()
        .filter(|v| !zero(v))
        .max_by(|a, b| a.re.total_cmp(&b.re))
        .filter(|v| v.re > tol * scale)
    {
        let kind = if v.im.abs() <= tol * scale {
            format!("the real eigenvalue λ = {:.6e} > 0: a divergence", v.re)
        } else {
            format!(
                "the eigenvalues λ = {:.6e} ± {:.6e}i with a positive real part: flutter (an \
                 oscillation that grows)",
                v.re,
                v.im.abs()
            )
        };
        return (Stability::Unstable, format!("unstable: {kind}"));
    }
    if eigenvalues.iter().any(zero) {
        return (
            Stability::Neutral,
            "a zero eigenvalue (K is singular): the linearization does not decide, higher-order \
             terms do"
                .to_string(),
        );
    }
    if eigenvalues.iter().all(|v| v.re < -tol * scale) {
        let slowest = eigenvalues
            .iter()
            .map(|v| -v.re)
            .fold(f64::INFINITY, f64::min);
        return (
            Stability::Stable,
            format!(
                "every eigenvalue has a negative real part (slowest decay rate {slowest:.6e}): \
                 asymptotically stable"
            ),
        );
    }
    let k = &lin.k;
    let symmetric = (k - k.transpose()).amax() <= tol * k.amax();
    let (k_values, (k_verdict, _)) = classify(k, tol);
    let c_sym = (&lin.c + lin.c.transpose()) * 0.5;
    let c_scale = c_sym.amax();
    let c_values = c_sym.symmetric_eigenvalues();
    let dissipative_or_none = c_values.iter().all(|&v| v >= -tol * c_scale);
    if symmetric && k_verdict == Stability::Stable && dissipative_or_none {
        return (
            Stability::Stable,
            "K is positive definite (a strict minimum of the effective potential U − T₀) and the \
             velocity forces do no positive work: stable (Lagrange–Dirichlet; gyroscopic and \
             dissipative forces keep it so), with undamped oscillations on the imaginary axis"
                .to_string(),
        );
    }
    if symmetric
        && k_values.iter().any(|&v| v < 0.0)
        && c_scale <= tol * lin.c.amax().max(f64::MIN_POSITIVE)
    {
        return (
            Stability::Stable,
            "gyroscopic stabilization: K has a negative eigenvalue, yet the gyroscopic forces \
             hold every eigenvalue on the imaginary axis; stable to linear order only, and any \
             damping destroys it (Kelvin–Tait–Chetaev)"
                .to_string(),
        );
    }
    (
        Stability::Neutral,
        "eigenvalues on the imaginary axis with non-conservative positional forces (K not \
         symmetric) or K not positive definite: marginal, the linearization does not decide"
            .to_string(),
    )
}
