//! Equilibria of the equations of motion, and statics by the principle of virtual work (seed
//! §3.1–3.2).
//!
//! A system at rest stays at rest where the accelerations vanish at q̇ = 0, that is where the
//! force side of eq. 55 vanishes:
//!
//! r(q) = −[∂L/∂q + Q″ − ∂Φ/∂q̇ − ∂²L/∂q̇∂t](t, q, q̇ = 0)
//!      = ∂U/∂q − Q″ − ∂T/∂q + ∂Φ/∂q̇ + ∂²T/∂q̇∂t   (all at q̇ = 0).
//!
//! When T is a quadratic form in q̇ (the seed's statics) only ∂U/∂q − Q″ is left: the forces do
//! no virtual work in any virtual displacement (eq. 27–29). When T has a part T₀ that does not
//! vanish at q̇ = 0 (a bead on a spinning hoop, coordinates in a rotating frame), −∂T₀/∂q is the
//! centrifugal force and the roots are the relative equilibria, the stationary points of the
//! effective potential U − T₀. Neither needs M: a system built only for statics may have
//! massless points (its accelerations then fail with [`Error::SingularMassMatrix`], as they
//! should).
//!
//! The solver is Newton's method with the exact stiffness K = ∂r/∂q from dual numbers (one
//! `Dual64` pass per coordinate through the model's own generic code, no finite differences),
//! globalised by a backtracking (Armijo) line search on ½|r|² and by Levenberg–Marquardt damping
//! when K is singular or a Newton step fails. The equilibrium is classified from the eigenvalues
//! of the linearized equations of motion there ([`crate::modes`]), which see damping, gyroscopic
//! and centrifugal terms; only where M is singular does K alone decide (the energy criterion).
//!
//! A system whose equations depend on t explicitly has no static equilibrium in general: a
//! configuration balanced at one instant is not at the next. Unless the caller asks for the
//! balance at a frozen time ([`StaticsOptions::frozen_time`]), [`equilibrium`] checks that r does
//! not change with t at the root it finds and fails with [`Error::NoStaticEquilibrium`] when it
//! does. A root that stays one (a driven pendulum hanging straight) is returned, but when its
//! linearization changes with t (parametric excitation) it is classified neutral: the
//! eigenvalues of one instant do not decide its stability. The structure
//! hints decide whether to look: a system that is neither time dependent, forced nor dissipative
//! ([`crate::Structure::conservative`]) cannot depend on t; any other is checked numerically,
//! which lets a steady rotation written with t in it (a hoop turning at a constant rate, stated by
//! particle positions r(t, q)) through.

use crate::Scalar;
use crate::checks::check_state;
use crate::dynamics::Dynamics;
use crate::error::{Error, Result};
use nalgebra::{Complex, DMatrix, DVector};
use num_dual::{Dual, Dual64};

/// Stopping rules and tolerances of [`equilibrium`].
///
/// The iteration stops successfully when either
/// - |r| ≤ `abs_tolerance` + `rel_tolerance` · F, where F is the largest of |∂U/∂q| and of the
///   other forces |Q″ + ∂T/∂q − ∂Φ/∂q̇ − ∂²T/∂q̇∂t| met at any accepted iterate (the guess
///   included) — the size of the loads being balanced, since the total residual may cancel to
///   zero at the root (Euclidean norms throughout); or
/// - an undamped Newton step Δq satisfies |Δq|∞ ≤ `step_tolerance` · |q|∞: Newton converges
///   quadratically there, so the step is taken and its end point returned.
///
/// A converged point then gets one more Newton step, kept if it does not increase |r| (counted
/// in the iterations, and skipped when none are left): it squares the error of a regular root, so q is far more accurate than
/// the residual tolerance alone would make it.
///
/// Because F is the largest load met, a force that only decays towards an "equilibrium at
/// infinity" (U = eˣ) is reported once it has fallen by `rel_tolerance`; check the returned q.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StaticsOptions {
    /// Absolute tolerance on |r|, in the units of the generalized forces (default 0: off).
    pub abs_tolerance: f64,
    /// Tolerance on |r| relative to the load scale F (default 1e-12).
    pub rel_tolerance: f64,
    /// Relative size of a Newton step below which the iteration has converged (default 1e-12).
    pub step_tolerance: f64,
    /// Upper bound on Newton/Levenberg–Marquardt iterations, failed line searches included
    /// (default 100).
    pub max_iterations: usize,
    /// Largest change of any coordinate in one iteration, |Δq|∞ (default ∞: no limit; set it to
    /// keep angles within one well, say).
    pub max_step: f64,
    /// Eigenvalues within ± `stability_tolerance` of the largest count as zero when the
    /// equilibrium is classified (default 1e-9; see [`crate::Modes::stability`]).
    pub stability_tolerance: f64,
    /// Solve for the balance of the forces frozen at the given t even when the equations depend
    /// on t (default `false`: such a system has no static equilibrium in general, and
    /// [`equilibrium`] fails with [`Error::NoStaticEquilibrium`]).
    pub frozen_time: bool,
}

impl Default for StaticsOptions {
    fn default() -> Self {
        Self {
            abs_tolerance: 0.0,
            rel_tolerance: 1e-12,
            step_tolerance: 1e-12,
            max_iterations: 100,
            max_step: f64::INFINITY,
            stability_tolerance: 1e-9,
            frozen_time: false,
        }
    }
}

impl StaticsOptions {
    fn validate(&self) -> Result<()> {
        let nonneg = [
            ("abs_tolerance", self.abs_tolerance),
            ("rel_tolerance", self.rel_tolerance),
            ("step_tolerance", self.step_tolerance),
            ("stability_tolerance", self.stability_tolerance),
        ];
        for (what, v) in nonneg {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::InvalidInput {
                    what,
                    why: format!("{v} is not a finite non-negative number"),
                });
            }
        }
        if self.max_step.is_nan() || self.max_step <= 0.0 {
            return Err(Error::InvalidInput {
                what: "max_step",
                why: format!(
                    "{} is not positive (use f64::INFINITY for no limit)",
                    self.max_step
                ),
            });
        }
        Ok(())
    }
}

/// The character of an equilibrium.
///
/// Decided from the eigenvalues of the linearized equations of motion ([`crate::modes`]; the
/// reason is stated in [`Equilibrium::reason`]): an eigenvalue with a positive real part makes
/// it unstable, a zero eigenvalue neutral, and it is stable when every eigenvalue has a
/// negative real part, or when K is positive definite (a strict minimum of the effective
/// potential U − T₀) with the rest on the imaginary axis, or when gyroscopic forces hold every
/// eigenvalue on the imaginary axis although K is not. Where M is singular (a model for statics
/// only) the eigenvalues λ of the symmetric part of K decide, the energy criterion of seed §3.2
/// (3): all λ > 0 stable, some λ < 0 unstable, else neutral.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stability {
    /// Small disturbances stay small.
    Stable,
    /// Some small disturbance grows.
    Unstable,
    /// The linearization does not decide (a zero eigenvalue, such as a lever whose loads
    /// balance at every angle, or eigenvalues on the imaginary axis under circulatory forces).
    Neutral,
}

/// An equilibrium found by [`equilibrium`].
#[derive(Debug, Clone, PartialEq)]
pub struct Equilibrium {
    /// The equilibrium configuration.
    pub q: DVector<f64>,
    /// |r(q)| at `q` (Euclidean norm).
    pub residual: f64,
    /// Iterations used (0 when the guess already satisfies the tolerance).
    pub iterations: usize,
    /// Stable, unstable or neutral.
    pub stability: Stability,
    /// Why: which eigenvalues decided, in words.
    pub reason: String,
    /// Eigenvalues of the symmetric part of K at `q`, ascending.
    pub eigenvalues: DVector<f64>,
    /// The stiffness K = ∂r/∂q at `q`: ∂²U/∂q² − ∂Q″/∂q, plus the centrifugal −∂²T₀/∂q².
    pub stiffness: DMatrix<f64>,
    /// Eigenvalues of the state matrix A of the linearization at (q, q̇ = 0)
    /// ([`crate::Modes::eigenvalues`]); `None` where M is singular.
    pub spectrum: Option<DVector<Complex<f64>>>,
}

/// Find an equilibrium of the equations of motion near `q_guess`: r(q) = 0 at q̇ = 0 (see the
/// module documentation), which is ∂U/∂q = Q″ (virtual work, eq. 27–29) when T is quadratic
/// in q̇ and the relative equilibrium of U − T₀ otherwise.
///
/// The residual is evaluated at time `t`. Fails with [`Error::NoStaticEquilibrium`] when the
/// equations depend on t and `options.frozen_time` is not set, [`Error::NoConvergence`] when no
/// root is reached within the options' bounds (there may be none: a net load that nothing
/// balances), [`Error::DimensionMismatch`] or [`Error::NonFinite`] for a bad guess,
/// [`Error::NonFinite`] when the model returns a non-finite residual at the guess or cannot
/// avoid one, and [`Error::InvalidInput`] for bad options.
///
/// ```
/// use lagrangian::{equilibrium, Stability, StaticsOptions};
/// use lagrangian::scenes::SimplePendulum;
/// # use approx::assert_relative_eq;
/// let pendulum = SimplePendulum::new(1.0, 2.0, 9.81).system();
/// let top = equilibrium(&pendulum, 0.0, &[2.8], &StaticsOptions::default()).unwrap();
/// assert_relative_eq!(top.q[0], std::f64::consts::PI, epsilon = 1e-12);
/// assert_eq!(top.stability, Stability::Unstable);
/// ```
pub fn equilibrium<S: Dynamics>(
    system: &S,
    t: f64,
    q_guess: &[f64],
    options: &StaticsOptions,
) -> Result<Equilibrium> {
    options.validate()?;
    check_state(system.dof(), t, q_guess, None)?;
    let mut problem = StaticProblem::new(system, t);
    let steady = !options.frozen_time && !system.structure().conservative();
    let solution = newton(&mut problem, DVector::from_column_slice(q_guess), options)?;
    if steady {
        problem.check_steady(solution.q.as_slice())?;
    }
    let (eigenvalues, static_verdict) = classify(&solution.k, options.stability_tolerance);
    let q = solution.q.as_slice();
    let (stability, reason, spectrum) =
        match crate::linearize::modes_unchecked(system, t, q, options.stability_tolerance) {
            Ok(modes) if steady && parametric(system, &modes.linearization)? => (
                Stability::Neutral,
                "the linearized equations change with t here (parametric excitation, a driven \
                 support): the eigenvalues at one instant do not decide, Floquet theory does"
                    .to_string(),
                Some(modes.eigenvalues),
            ),
            Ok(modes) => (modes.stability, modes.reason, Some(modes.eigenvalues)),
            Err(Error::SingularMassMatrix { .. }) => {
                let (stability, why) = static_verdict;
                let reason = format!(
                    "M is singular here (a model for statics only), so the stiffness alone \
                     decides (energy criterion): {why}"
                );
                (stability, reason, None)
            }
            Err(e) => return Err(e),
        };
    Ok(Equilibrium {
        q: solution.q,
        residual: solution.r.norm(),
        iterations: solution.iterations,
        stability,
        reason,
        eigenvalues,
        stiffness: solution.k,
        spectrum,
    })
}

/// Whether the state matrix A at the equilibrium changes with t (at the [`STEADY_OFFSETS`]).
fn parametric<S: Dynamics>(system: &S, lin: &crate::Linearization) -> Result<bool> {
    let q = lin.q.as_slice();
    let rest = vec![0.0; q.len()];
    for dt in STEADY_OFFSETS {
        let other = crate::linearize(system, lin.t + dt, q, &rest)?;
        if (&other.a - &lin.a).amax() > STEADY_TOLERANCE * lin.a.amax().max(other.a.amax()) {
            return Ok(true);
        }
    }
    Ok(false)
}

/// The stiffness K = ∂r/∂q at (t, q, q̇ = 0), r as in the module documentation, by one dual pass
/// per coordinate.
///
/// At an equilibrium this is the K of the linearised equations M δq̈ + C δq̇ + K δq = 0,
/// centrifugal stiffness included.
pub fn static_stiffness<S: Dynamics>(system: &S, t: f64, q: &[f64]) -> Result<DMatrix<f64>> {
    check_state(system.dof(), t, q, None)?;
    StaticProblem::new(system, t).jacobian(q)
}

/// [`static_stiffness`] for any system, inputs unchecked.
pub(crate) fn static_stiffness_of<S: Dynamics + ?Sized>(
    system: &S,
    t: f64,
    q: &[f64],
) -> Result<DMatrix<f64>> {
    StaticProblem::new(system, t).jacobian(q)
}

/// r(q) at (t, q, q̇ = 0) and the load scale F it balances (see [`StaticsOptions`]).
pub(crate) fn static_residual<S: Dynamics + ?Sized>(
    system: &S,
    t: f64,
    q: &[f64],
) -> Result<(DVector<f64>, f64)> {
    StaticProblem::new(system, t).residual(q)
}

/// Eigenvalues of the symmetric part of K, ascending, and the stability they imply with the
/// reason.
pub(crate) fn classify(k: &DMatrix<f64>, tol: f64) -> (DVector<f64>, (Stability, String)) {
    let sym = (k + k.transpose()) * 0.5;
    let mut values: Vec<f64> = sym.symmetric_eigenvalues().iter().copied().collect();
    values.sort_by(f64::total_cmp);
    let scale = values.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
    let zero = tol * scale;
    let verdict = if let Some(&v) = values.iter().find(|&&v| v < -zero) {
        (
            Stability::Unstable,
            format!("K has the negative eigenvalue {v:.6e} (a maximum or saddle of the potential)"),
        )
    } else if scale > 0.0 && values.iter().all(|&v| v > zero) {
        (
            Stability::Stable,
            "K is positive definite (a strict minimum of the potential)".to_string(),
        )
    } else {
        (
            Stability::Neutral,
            "K has a zero eigenvalue (higher-order terms decide)".to_string(),
        )
    };
    (DVector::from_vec(values), verdict)
}

/// A residual r(q) with its Jacobian: what the Newton core solves.
trait Residual {
    /// r(q) and the load scale F at q. Fails (`NonFinite`) when r is not finite.
    fn residual(&mut self, q: &[f64]) -> Result<(DVector<f64>, f64)>;
    /// K = ∂r/∂q. Fails (`NonFinite`) when K is not finite.
    fn jacobian(&mut self, q: &[f64]) -> Result<DMatrix<f64>>;
}

/// r(q) of a system at time t, q̇ = 0.
struct StaticProblem<'a, S: ?Sized> {
    system: &'a S,
    t: f64,
    forced: bool,
    dissipative: bool,
    time_dependent: bool,
}

/// Times after t at which r is compared with r(t) to see whether it depends on t: irrational
/// offsets, so that no periodic forcing is caught at the same phase.
const STEADY_OFFSETS: [f64; 3] = [
    0.618_033_988_749_894_9,
    std::f64::consts::SQRT_2,
    7.389_056_098_930_65,
];
/// A change of r with t beyond this fraction of the load scale is a time-dependent balance.
const STEADY_TOLERANCE: f64 = 1e-9;

impl<'a, S: Dynamics + ?Sized> StaticProblem<'a, S> {
    fn new(system: &'a S, t: f64) -> Self {
        let s = system.structure();
        Self {
            system,
            t,
            forced: s.forced,
            dissipative: s.dissipative,
            time_dependent: s.time_dependent,
        }
    }

    /// ∂U/∂q into `grad` and the other forces at rest, Q″ + ∂T/∂q − ∂Φ/∂q̇ − ∂²T/∂q̇∂t at
    /// (t, q, 0), into `load`, on any scalar (r = grad − load).
    fn terms<D: Scalar>(&self, t: f64, q: &[D], grad: &mut [D], load: &mut [D]) {
        let n = q.len();
        let t = D::from(t);
        self.system.potential_gradient_into(t, q, grad);
        load.fill(D::zero());
        let at_rest = vec![D::zero(); n];
        let mut work = vec![D::zero(); n];
        if self.forced {
            self.system
                .generalized_forces_into(t, q, &at_rest, &mut work);
            add(load, &work, 1.0);
        }
        if self.dissipative {
            self.system
                .dissipative_forces_into(t, q, &at_rest, &mut work);
            add(load, &work, 1.0);
        }
        // ∂T/∂q at q̇ = 0: the centrifugal force of T₀, one dual pass per coordinate.
        let tt = Dual::from_re(t);
        let rest = vec![Dual::from_re(D::zero()); n];
        let mut qs: Vec<Dual<D>> = q.iter().map(|&x| Dual::from_re(x)).collect();
        for i in 0..n {
            qs[i].eps = D::one();
            load[i] += self.system.kinetic_energy(tt, &qs, &rest).eps;
            qs[i].eps = D::zero();
        }
        if self.time_dependent {
            // −∂²T/∂q̇∂t at q̇ = 0: p = ∂T/∂q̇ seeded in t.
            let qs: Vec<Dual<D>> = q.iter().map(|&x| Dual::from_re(x)).collect();
            let mut p = vec![Dual::from_re(D::zero()); n];
            self.system
                .momenta_into(Dual::new(t, D::one()), &qs, &rest, &mut p);
            for (l, p) in load.iter_mut().zip(&p) {
                *l -= p.eps;
            }
        }
    }

    fn residual_at(&self, t: f64, q: &[f64]) -> Result<(DVector<f64>, f64)> {
        let n = q.len();
        let (mut grad, mut load) = (vec![0.0; n], vec![0.0; n]);
        self.terms(t, q, &mut grad, &mut load);
        let r = DVector::from_iterator(n, grad.iter().zip(&load).map(|(g, f)| g - f));
        let scale = norm(&grad).max(norm(&load));
        if r.iter().all(|v| v.is_finite()) && scale.is_finite() {
            Ok((r, scale))
        } else {
            Err(Error::NonFinite {
                what: "static residual ∂U/∂q − Q″ − ∂T/∂q + ∂Φ/∂q̇ (at q̇ = 0)",
                t,
            })
        }
    }

    /// `Err(NoStaticEquilibrium)` when r(q) changes with t.
    fn check_steady(&self, q: &[f64]) -> Result<()> {
        let (r, scale) = self.residual_at(self.t, q)?;
        for dt in STEADY_OFFSETS {
            let other = self.t + dt;
            let (r2, scale2) = self.residual_at(other, q)?;
            let change = (&r2 - &r).norm();
            if change > STEADY_TOLERANCE * scale.max(scale2) {
                return Err(Error::NoStaticEquilibrium {
                    t: self.t,
                    other,
                    q: q.to_vec(),
                    change,
                });
            }
        }
        Ok(())
    }
}

/// `acc += s · x`.
fn add<D: Scalar>(acc: &mut [D], x: &[D], s: f64) {
    for (a, &x) in acc.iter_mut().zip(x) {
        *a += x * s;
    }
}

impl<S: Dynamics + ?Sized> Residual for StaticProblem<'_, S> {
    fn residual(&mut self, q: &[f64]) -> Result<(DVector<f64>, f64)> {
        self.residual_at(self.t, q)
    }

    fn jacobian(&mut self, q: &[f64]) -> Result<DMatrix<f64>> {
        let n = q.len();
        let zero = Dual64::from_re(0.0);
        let (mut qs, mut grad, mut load) = (vec![zero; n], vec![zero; n], vec![zero; n]);
        let mut k = DMatrix::zeros(n, n);
        for j in 0..n {
            for (i, (s, &x)) in qs.iter_mut().zip(q).enumerate() {
                *s = Dual64::new(x, if i == j { 1.0 } else { 0.0 });
            }
            self.terms(self.t, &qs, &mut grad, &mut load);
            for i in 0..n {
                k[(i, j)] = grad[i].eps - load[i].eps;
            }
        }
        if k.iter().all(|v| v.is_finite()) {
            Ok(k)
        } else {
            Err(Error::NonFinite {
                what: "static stiffness ∂r/∂q",
                t: self.t,
            })
        }
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// A root of the residual, with the residual and K there.
#[derive(Debug)]
struct Solution {
    q: DVector<f64>,
    r: DVector<f64>,
    k: DMatrix<f64>,
    iterations: usize,
}

/// Armijo constant: accept a step that achieves this fraction of the predicted decrease.
const ARMIJO: f64 = 1e-4;
/// Smallest line-search step fraction before the step counts as failed.
const MIN_STEP_FRACTION: f64 = 1e-10;
/// First Levenberg–Marquardt damping, relative to the largest diagonal entry of KᵀK.
const LM_INITIAL: f64 = 1e-3;
/// Damping below which the iteration returns to plain Newton steps.
const LM_OFF: f64 = 1e-7;
/// Damping above which no descent is possible: a minimum of |r| that is not a root.
const LM_MAX: f64 = 1e12;
/// A full-pivot LU pivot ratio below this makes K numerically singular.
const SINGULAR_PIVOT_RATIO: f64 = 1e-14;

/// Newton's method with an Armijo line search on ½|r|² and Levenberg–Marquardt fallback.
fn newton<P: Residual>(
    problem: &mut P,
    q0: DVector<f64>,
    options: &StaticsOptions,
) -> Result<Solution> {
    let mut q = q0;
    let (mut r, mut scale) = problem.residual(q.as_slice())?;
    let mut k = problem.jacobian(q.as_slice())?;
    let mut lambda = 0.0;
    let mut iterations = 0;
    loop {
        let norm = r.norm();
        if norm <= options.abs_tolerance + options.rel_tolerance * scale {
            let converged = Solution {
                q,
                r,
                k,
                iterations,
            };
            return Ok(if iterations < options.max_iterations {
                polish(problem, converged)
            } else {
                converged
            });
        }
        if iterations == options.max_iterations {
            return Err(no_convergence(iterations, norm, &q));
        }
        iterations += 1;

        let g = k.tr_mul(&r);
        let newton_step = if lambda == 0.0 {
            newton_direction(&k, &r)
        } else {
            None
        };
        let (mut d, is_newton) = match newton_step {
            Some(d) => {
                if d.amax() <= options.step_tolerance * q.amax() {
                    let q_new = &q + &d;
                    let (r_new, _) = problem.residual(q_new.as_slice())?;
                    let k_new = problem.jacobian(q_new.as_slice())?;
                    return Ok(Solution {
                        q: q_new,
                        r: r_new,
                        k: k_new,
                        iterations,
                    });
                }
                (d, true)
            }
            None => {
                if g.iter().all(|&x| x == 0.0) {
                    // |r|² is stationary here but r ≠ 0: no descent direction exists.
                    return Err(no_convergence(iterations, norm, &q));
                }
                if lambda == 0.0 {
                    lambda = LM_INITIAL;
                }
                match lm_direction(&k, &g, lambda) {
                    Some(d) => (d, false),
                    None => {
                        lambda *= 10.0;
                        if lambda > LM_MAX {
                            return Err(no_convergence(iterations, norm, &q));
                        }
                        continue;
                    }
                }
            }
        };
        let longest = d.amax();
        if longest > options.max_step {
            d *= options.max_step / longest;
        }
        let slope = g.dot(&d);
        let searched = if slope < 0.0 {
            line_search(problem, &q, &d, 0.5 * norm * norm, slope)?
        } else {
            None
        };
        match searched {
            Some((q_new, r_new, scale_new)) => {
                k = problem.jacobian(q_new.as_slice())?;
                q = q_new;
                r = r_new;
                scale = scale.max(scale_new);
                if !is_newton {
                    lambda *= 0.1;
                    if lambda < LM_OFF {
                        lambda = 0.0;
                    }
                }
            }
            None => {
                lambda = if lambda == 0.0 {
                    LM_INITIAL
                } else {
                    lambda * 10.0
                };
                if lambda > LM_MAX {
                    return Err(no_convergence(iterations, norm, &q));
                }
            }
        }
    }
}

/// One more Newton step from a converged point, kept when it does not increase |r|: near a
/// regular root it squares the error, so q is accurate far beyond the residual tolerance.
fn polish<P: Residual>(problem: &mut P, s: Solution) -> Solution {
    let Some(d) = newton_direction(&s.k, &s.r) else {
        return s;
    };
    let q = &s.q + &d;
    if q == s.q {
        return s;
    }
    match (
        problem.residual(q.as_slice()),
        problem.jacobian(q.as_slice()),
    ) {
        (Ok((r, _)), Ok(k)) if r.norm() <= s.r.norm() => Solution {
            q,
            r,
            k,
            iterations: s.iterations + 1,
        },
        _ => s,
    }
}

/// The Newton step −K⁻¹r, or `None` when K is numerically singular.
fn newton_direction(k: &DMatrix<f64>, r: &DVector<f64>) -> Option<DVector<f64>> {
    let lu = k.clone().full_piv_lu();
    let u = lu.u();
    let n = u.nrows();
    let (first, last) = (u[(0, 0)].abs(), u[(n - 1, n - 1)].abs());
    if !first.is_finite() || first == 0.0 || last <= SINGULAR_PIVOT_RATIO * first {
        return None;
    }
    let d = -lu.solve(r)?;
    d.iter().all(|v| v.is_finite()).then_some(d)
}

/// The damped step −(KᵀK + λ μ I)⁻¹ Kᵀr, μ the largest diagonal entry of KᵀK.
fn lm_direction(k: &DMatrix<f64>, g: &DVector<f64>, lambda: f64) -> Option<DVector<f64>> {
    let mut a = k.tr_mul(k);
    let mu = a.diagonal().amax();
    if !mu.is_finite() || mu == 0.0 {
        return None;
    }
    for i in 0..a.nrows() {
        a[(i, i)] += lambda * mu;
    }
    let d = -a.cholesky()?.solve(g);
    d.iter().all(|v| v.is_finite()).then_some(d)
}

/// Backtracking from the full step until ½|r|² drops by the Armijo fraction of the predicted
/// decrease. Trial points where the model is not finite are stepped back from; if no finite
/// point was met at all, that error is returned. `None` when no step fraction is accepted.
#[allow(clippy::type_complexity)]
fn line_search<P: Residual>(
    problem: &mut P,
    q: &DVector<f64>,
    d: &DVector<f64>,
    merit: f64,
    slope: f64,
) -> Result<Option<(DVector<f64>, DVector<f64>, f64)>> {
    let mut alpha = 1.0;
    let mut last_error = None;
    let mut met_finite = false;
    while alpha >= MIN_STEP_FRACTION {
        let q_new = q + d * alpha;
        if q_new == *q {
            break;
        }
        match problem.residual(q_new.as_slice()) {
            Ok((r_new, scale)) => {
                met_finite = true;
                let merit_new = 0.5 * r_new.norm_squared();
                if merit_new <= merit + ARMIJO * alpha * slope {
                    return Ok(Some((q_new, r_new, scale)));
                }
            }
            Err(e @ Error::NonFinite { .. }) => last_error = Some(e),
            Err(e) => return Err(e),
        }
        alpha *= 0.5;
    }
    match last_error {
        Some(e) if !met_finite => Err(e),
        _ => Ok(None),
    }
}

fn no_convergence(iterations: usize, residual: f64, q: &DVector<f64>) -> Error {
    Error::NoConvergence {
        iterations,
        residual,
        q: q.iter().copied().collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// A residual given by closures, for testing the Newton core on its own.
    struct Fun<R, J>(R, J);

    impl<R, J> Residual for Fun<R, J>
    where
        R: FnMut(&[f64]) -> Vec<f64>,
        J: FnMut(&[f64]) -> Vec<f64>,
    {
        fn residual(&mut self, q: &[f64]) -> Result<(DVector<f64>, f64)> {
            let r = DVector::from_vec((self.0)(q));
            if r.iter().all(|v| v.is_finite()) {
                let scale = r.norm();
                Ok((r, scale))
            } else {
                Err(Error::NonFinite {
                    what: "test residual",
                    t: 0.0,
                })
            }
        }
        fn jacobian(&mut self, q: &[f64]) -> Result<DMatrix<f64>> {
            let n = q.len();
            Ok(DMatrix::from_row_slice(n, n, &(self.1)(q)))
        }
    }

    #[test]
    fn newton_circle_and_hyperbola() {
        // x² + y² = 5, x y = 2: roots (1, 2), (2, 1) and their negatives.
        let mut f = Fun(
            |q: &[f64]| vec![q[0] * q[0] + q[1] * q[1] - 5.0, q[0] * q[1] - 2.0],
            |q: &[f64]| vec![2.0 * q[0], 2.0 * q[1], q[1], q[0]],
        );
        let opts = StaticsOptions::default();
        let s = newton(&mut f, DVector::from_vec(vec![0.7, 2.9]), &opts).unwrap();
        assert_relative_eq!(s.q[0], 1.0, epsilon = 1e-14);
        assert_relative_eq!(s.q[1], 2.0, epsilon = 1e-14);
        assert!(s.iterations <= 10, "{} iterations", s.iterations);
        let s = newton(&mut f, DVector::from_vec(vec![-3.0, -0.5]), &opts).unwrap();
        assert_relative_eq!(s.q[0], -2.0, epsilon = 1e-14);
        assert_relative_eq!(s.q[1], -1.0, epsilon = 1e-14);
    }

    #[test]
    fn newton_atan_needs_line_search() {
        // Plain Newton on atan diverges from |x₀| > 1.39; the line search brings it home.
        let mut f = Fun(
            |q: &[f64]| vec![q[0].atan()],
            |q: &[f64]| vec![1.0 / (1.0 + q[0] * q[0])],
        );
        let s = newton(&mut f, DVector::from_vec(vec![10.0]), &Default::default()).unwrap();
        assert!(s.q[0].abs() < 1e-12, "q = {}", s.q[0]);
        assert!(s.iterations <= 30, "{} iterations", s.iterations);
    }

    #[test]
    fn newton_steps_back_from_non_finite() {
        // r = √q − 1: the first full step from q = 9 lands at q = −3 where √q is NaN.
        let mut f = Fun(
            |q: &[f64]| vec![q[0].sqrt() - 1.0],
            |q: &[f64]| vec![0.5 / q[0].sqrt()],
        );
        let s = newton(&mut f, DVector::from_vec(vec![9.0]), &Default::default()).unwrap();
        assert_relative_eq!(s.q[0], 1.0, epsilon = 1e-14);
    }

    #[test]
    fn newton_singular_jacobian_uses_damping() {
        // r = (x² + y − 1, x − y): roots x = y = (−1 ± √5)/2; K is singular on x = −½, where
        // the guess starts.
        let mut f = Fun(
            |q: &[f64]| vec![q[0] * q[0] + q[1] - 1.0, q[0] - q[1]],
            |q: &[f64]| vec![2.0 * q[0], 1.0, 1.0, -1.0],
        );
        let guess = DVector::from_vec(vec![-0.5, 0.0]);
        let s = newton(&mut f, guess, &Default::default()).unwrap();
        let root = if s.q[0] > 0.0 {
            0.5 * (5.0_f64.sqrt() - 1.0)
        } else {
            -0.5 * (5.0_f64.sqrt() + 1.0)
        };
        assert_relative_eq!(s.q[0], root, epsilon = 1e-14);
        assert_relative_eq!(s.q[1], root, epsilon = 1e-14);
    }

    #[test]
    fn newton_no_root_fails() {
        // r = q² + 1 ≥ 1 has no root; |r| has a minimum at q = 0 where K = 0.
        let mut f = Fun(
            |q: &[f64]| vec![q[0] * q[0] + 1.0],
            |q: &[f64]| vec![2.0 * q[0]],
        );
        for q0 in [1.0, 0.7, -2.3] {
            let e = newton(&mut f, DVector::from_vec(vec![q0]), &Default::default()).unwrap_err();
            match e {
                Error::NoConvergence {
                    iterations,
                    residual,
                    ..
                } => {
                    assert!(iterations <= 100);
                    assert!(residual >= 1.0);
                }
                other => panic!("expected NoConvergence, got {other:?}"),
            }
        }
    }

    #[test]
    fn newton_iteration_bound_is_kept() {
        let mut f = Fun(
            |q: &[f64]| vec![q[0].atan()],
            |q: &[f64]| vec![1.0 / (1.0 + q[0] * q[0])],
        );
        let opts = StaticsOptions {
            max_iterations: 2,
            ..Default::default()
        };
        let e = newton(&mut f, DVector::from_vec(vec![10.0]), &opts).unwrap_err();
        assert!(matches!(e, Error::NoConvergence { iterations: 2, .. }));
    }

    #[test]
    fn classify_signs() {
        let tol = 1e-9;
        let m = |v: &[f64]| DMatrix::from_row_slice(2, 2, v);
        assert_eq!(
            classify(&m(&[2.0, 1.0, 1.0, 2.0]), tol).1.0,
            Stability::Stable
        );
        assert_eq!(
            classify(&m(&[1.0, 2.0, 2.0, 1.0]), tol).1.0,
            Stability::Unstable
        );
        assert_eq!(
            classify(&m(&[1.0, 1.0, 1.0, 1.0]), tol).1.0,
            Stability::Neutral
        );
        assert_eq!(classify(&m(&[0.0; 4]), tol).1.0, Stability::Neutral);
        // Only the symmetric part counts: a pure rotation generator is neutral.
        assert_eq!(
            classify(&m(&[0.0, 1.0, -1.0, 0.0]), tol).1.0,
            Stability::Neutral
        );
        let (values, _) = classify(&m(&[3.0, 1.0, 1.0, 3.0]), tol);
        assert_relative_eq!(values[0], 2.0, epsilon = 1e-14);
        assert_relative_eq!(values[1], 4.0, epsilon = 1e-14);
    }
}
