//! Integrators of the equations of motion (seed eq. 55): one [`solve`] for every method.
//!
//! The state is y = (q, q̇) and the first-order system ẏ = (q̇, q̈) with q̈ from
//! [`Dynamics::accelerations_into`]. Families:
//!
//! | method | family | step | for |
//! |---|---|---|---|
//! | `rk4` | explicit Runge–Kutta, order 4 | fixed | smooth problems, reference runs |
//! | `dopri5` | Dormand–Prince 5(4), dense output of order 4 | adaptive | forced, dissipative, non-stiff |
//! | `dop853` | Dormand–Prince 8(5,3), dense output of order 7 | adaptive | the same, at tight tolerances |
//! | `stormer_verlet`, `yoshida4/6/8`, `blanes_moan4` | explicit symplectic splitting | fixed | separable systems over long times |
//! | `midpoint` | variational (discrete Hamilton / Lagrange–d'Alembert principle), order 2, implicit | fixed | any Lagrangian over long times; forced or damped runs with the right energy decay |
//! | `gauss4`, `gauss6` | Gauss–Legendre collocation on (q, p), order 4 / 6, implicit | fixed | non-separable systems (M(q), gyroscopic, velocity-dependent L) over long times |
//! | `radau5` | Radau IIA, order 5, implicit, L-stable | adaptive | stiff problems: stiff springs, heavy damping |
//!
//! The splitting methods need a separable system — T = ½ q̇ᵀMq̇ with constant M, U(t, q), no
//! Rayleigh dissipation, Q″ free of q̇ — and then step q̇ += h M⁻¹(Q″ − ∂U/∂q) (the kick, M
//! factored once) and q += h q̇ (the drift). They are symplectic and symmetric: the energy
//! error stays bounded over long times and a run backwards retraces the run forwards. Asked of
//! another system they return [`Error::UnsupportedMethod`] naming the methods that fit.
//!
//! The implicit symplectic methods work on (q, p), p = ∂L/∂q̇, and serve any Lagrangian with an
//! invertible M; Q″ and −∂Φ/∂q̇ enter through the Lagrange–d'Alembert principle (eq. 35). Their
//! equations are solved by Newton with AD Jacobians to round-off, so they stay symmetric; a step
//! whose Newton iteration fails is retried as two half steps, at most ten times nested, then
//! [`Error::NewtonFailure`]. Their `rhs_evaluations` count evaluations of (p, ∂L/∂q + Q″ −
//! ∂Φ/∂q̇) at one stage; Radau's count evaluations of q̈. `jacobian_evaluations` and
//! `factorizations` count AD Jacobians and LU (or LDLᵀ) factorizations.
//!
//! Failure is typed and early: [`Error::StepSizeTooSmall`], [`Error::TooManySteps`],
//! [`Error::NonFinite`] with the time it appeared, [`Error::Stiffness`] when Hairer's test
//! finds that an explicit adaptive method is limited by stability rather than accuracy,
//! [`Error::UnstableStep`] before a fixed-step explicit run whose `dt` lies outside the method's
//! stability region for a mode of the system linearised at the start (a stiff spring under RK4
//! or Störmer–Verlet: refused with the largest stable `dt`, never a silently exploding answer),
//! and [`Error::NewtonFailure`] when an implicit step cannot be solved. [`solve_partial`] keeps
//! what a failed run computed: [`Failed`] carries the trajectory up to the last accepted step.
//! With the `parallel` feature, `solve_many` runs an ensemble of them on a rayon thread pool
//! (`ensemble.rs`), bit for bit as a serial loop would.
//!
//! A new method is one file implementing the crate's internal `Integrator` trait and one line in
//! its registry (`src/integrators/mod.rs`).
//!
//! ```
//! use lagrangian::integrators::{Method, Options, solve};
//! use lagrangian::scenes::SimplePendulum;
//! # use approx::assert_relative_eq;
//! let pendulum = SimplePendulum::new(1.0, 1.0, 9.81).system();
//! let sol = solve(&pendulum, &[0.1], &[0.0], (0.0, 2.0), Method::Dop853,
//!                 &Options::adaptive(1e-10, 1e-12)).unwrap();
//! let (t, q, _) = sol.last().unwrap();
//! assert_eq!(t, 2.0);
//! // Small swings: θ ≈ 0.1 cos(√(g/l) t), up to the O(θ³) anharmonic shift.
//! assert_relative_eq!(q[0], 0.1 * (9.81_f64.sqrt() * 2.0).cos(), epsilon = 2e-3);
//! ```

mod auto;
mod dense;
#[cfg(feature = "parallel")]
mod ensemble;
mod gauss;
mod newton;
mod options;
mod radau;
mod runge_kutta;
mod solution;
mod stability;
mod stiffness;
mod symplectic;
mod tableau;
mod variational;

#[cfg(feature = "parallel")]
pub use ensemble::{RunResult, Systems, solve_many};
pub(crate) use newton::acceleration_jacobian;
#[cfg(test)]
pub(crate) use newton::jacobian;
pub use options::{Options, Output};
pub use solution::{Failed, Solution, Statistics};
pub use symplectic::SymplecticTableau;
pub use tableau::{Controller, DenseOutput, ErrorEstimate, StiffnessTest, Tableau};

use crate::dynamics::{Dynamics, check_state};
use crate::error::{Error, Result};
use gauss::{Gauss, GaussTableau};
use radau::Radau;
use runge_kutta::ExplicitRk;
use solution::Recorder;
use symplectic::Splitting;
use variational::Variational;

/// What every method implements. The registry dispatches on [`Method`] to a value of a type
/// implementing it.
pub(crate) trait Integrator {
    /// Order of convergence.
    fn order(&self) -> usize;

    /// Whether the step size is controlled by an error estimate when no `dt` is given.
    fn adaptive(&self) -> bool;

    /// Whether a step is explicit: then a fixed `dt` has a stability limit, checked before the
    /// run (see [`stability`]).
    fn explicit(&self) -> bool;

    /// `Err(why)` when the method cannot integrate this system from this state; every system
    /// fits by default.
    fn fits<S: Dynamics + ?Sized>(
        &self,
        _system: &S,
        _t0: f64,
        _q0: &[f64],
        _qd0: &[f64],
    ) -> std::result::Result<(), String> {
        Ok(())
    }

    /// Integrate over the run's span, recording into `run.out`.
    fn integrate<S: Dynamics + ?Sized>(&self, run: &mut Run<'_, S>) -> Result<()>;
}

/// A generic operation on the integrator behind a [`Method`].
trait Visit {
    type Out;
    fn visit<I: Integrator>(self, integrator: I) -> Self::Out;
}

/// The one place that lists the methods: `Variant = "name" => integrator`.
macro_rules! registry {
    ($( $(#[$doc:meta])* $variant:ident = $name:literal => $make:expr ),+ $(,)?) => {
        /// An integration method; [`Method::Auto`] chooses one from the system's structure.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        #[non_exhaustive]
        pub enum Method {
            /// Choose from the structure, the options and the initial state; the choice and its
            /// reason are in [`Statistics::choice`]:
            ///
            /// 1. conservative (no Φ, no Q″, no explicit t) with a fixed `dt`: `blanes_moan4` when
            ///    separable (constant M, U(q)), otherwise `gauss4` (symplectic for any L);
            /// 2. otherwise (forced, dissipative, time-dependent, or tolerances only): `radau5`
            ///    when the system is stiff, else `dop853` (adaptive, or at the fixed `dt`).
            ///
            /// Stiff means: at the initial state, the Jacobian of (q̇, q̈) has a decaying
            /// (relaxation) mode at least 1000 times faster than every mode the solution must
            /// follow — the oscillatory and the growing ones, and 1/|span| — so an explicit
            /// method's step would be set by stability, not accuracy. The eigenvalues come from
            /// the AD Jacobian (2n dual evaluations, one Schur decomposition; up to 64
            /// coordinates). Symplectic methods need a fixed `dt`: a conservative system given
            /// tolerances only gets `dop853`, and the reason says to give `dt` for a symplectic
            /// method.
            Auto,
            $( $(#[$doc])* $variant, )+
        }

        impl Method {
            /// Every concrete method, in registry order.
            pub const ALL: &'static [Method] = &[$(Method::$variant),+];

            /// The method's name, as [`str::parse`] accepts it.
            pub fn name(self) -> &'static str {
                match self {
                    Method::Auto => "auto",
                    $(Method::$variant => $name,)+
                }
            }

            fn visit<V: Visit>(self, v: V) -> Option<V::Out> {
                match self {
                    Method::Auto => None,
                    $(Method::$variant => Some(v.visit($make)),)+
                }
            }
        }
    };
}

registry! {
    /// Classical Runge–Kutta of order 4, fixed step.
    Rk4 = "rk4" => ExplicitRk::new(Tableau::rk4()),
    /// Dormand–Prince 5(4) with step control, dense output and stiffness test (Hairer's `dopri5`).
    Dopri5 = "dopri5" => ExplicitRk::new(Tableau::dopri5()),
    /// Dormand–Prince 8(5,3) with step control, dense output and stiffness test (Hairer's `dop853`).
    Dop853 = "dop853" => ExplicitRk::new(Tableau::dop853()),
    /// Störmer–Verlet (velocity Verlet, kick–drift–kick), order 2, symplectic.
    StormerVerlet = "stormer_verlet" => Splitting::new(SymplecticTableau::stormer_verlet()),
    /// Yoshida's triple-jump composition of Störmer–Verlet, order 4, symplectic.
    Yoshida4 = "yoshida4" => Splitting::new(SymplecticTableau::yoshida4()),
    /// Yoshida's 7-stage composition (solution A), order 6, symplectic.
    Yoshida6 = "yoshida6" => Splitting::new(SymplecticTableau::yoshida6()),
    /// Yoshida's 15-stage composition (solution D), order 8, symplectic.
    Yoshida8 = "yoshida8" => Splitting::new(SymplecticTableau::yoshida8()),
    /// Blanes & Moan's 6-stage symplectic Runge–Kutta–Nyström method SRKN₆ᵇ, order 4.
    BlanesMoan4 = "blanes_moan4" => Splitting::new(SymplecticTableau::blanes_moan4()),
    /// The midpoint variational integrator (discrete Hamilton and Lagrange–d'Alembert
    /// principles), order 2: implicit, symplectic and symmetric for any Lagrangian.
    Midpoint = "midpoint" => Variational,
    /// Gauss–Legendre collocation with 2 stages on (q, p), order 4: implicit, symplectic and
    /// symmetric for any Lagrangian.
    Gauss4 = "gauss4" => Gauss::new(GaussTableau::gauss4()),
    /// Gauss–Legendre collocation with 3 stages on (q, p), order 6: implicit, symplectic and
    /// symmetric for any Lagrangian.
    Gauss6 = "gauss6" => Gauss::new(GaussTableau::gauss6()),
    /// Radau IIA of order 5 (Hairer & Wanner's RADAU5): implicit, L-stable, adaptive, with the
    /// AD Jacobian; for stiff problems.
    Radau5 = "radau5" => Radau,
}

struct Info;
impl Visit for Info {
    type Out = (usize, bool, bool);
    fn visit<I: Integrator>(self, i: I) -> (usize, bool, bool) {
        (i.order(), i.adaptive(), i.explicit())
    }
}

impl Method {
    /// Order of convergence; `None` for [`Method::Auto`].
    pub fn order(self) -> Option<usize> {
        self.visit(Info).map(|(order, _, _)| order)
    }

    /// Whether the method controls its step size when no fixed `dt` is given; `None` for
    /// [`Method::Auto`].
    pub fn is_adaptive(self) -> Option<bool> {
        self.visit(Info).map(|(_, adaptive, _)| adaptive)
    }

    /// Whether the method is explicit (its fixed steps have a stability limit); `None` for
    /// [`Method::Auto`].
    pub fn is_explicit(self) -> Option<bool> {
        self.visit(Info).map(|(_, _, explicit)| explicit)
    }

    /// The methods that can integrate `system` from this state: every method except the
    /// explicit splittings serves any system with an invertible mass matrix; those need a
    /// separable one without velocity-dependent forces.
    pub fn fitting<S: Dynamics + ?Sized>(
        system: &S,
        t0: f64,
        q0: &[f64],
        qd0: &[f64],
    ) -> Vec<Method> {
        Method::ALL
            .iter()
            .copied()
            .filter(|m| {
                matches!(
                    m.visit(Fits {
                        system,
                        t0,
                        q0,
                        qd0
                    }),
                    Some(Ok(()))
                )
            })
            .collect()
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Method {
    type Err = Error;

    /// Parse a method name (`"auto"`, `"dop853"`, `"yoshida6"`, …), ignoring case.
    fn from_str(s: &str) -> Result<Self> {
        let lower = s.to_ascii_lowercase();
        let lower = if lower == "verlet" {
            "stormer_verlet".into()
        } else {
            lower
        };
        if lower == "auto" {
            return Ok(Method::Auto);
        }
        Method::ALL
            .iter()
            .copied()
            .find(|m| m.name() == lower)
            .ok_or_else(|| Error::InvalidInput {
                what: "method",
                why: format!(
                    "unknown method {s:?}; known: auto, {}",
                    Method::ALL
                        .iter()
                        .map(|m| m.name())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            })
    }
}

struct Fits<'a, S: ?Sized> {
    system: &'a S,
    t0: f64,
    q0: &'a [f64],
    qd0: &'a [f64],
}
impl<S: Dynamics + ?Sized> Visit for Fits<'_, S> {
    type Out = std::result::Result<(), String>;
    fn visit<I: Integrator>(self, i: I) -> Self::Out {
        i.fits(self.system, self.t0, self.q0, self.qd0)
    }
}

struct Integrate<'r, 'a, S: ?Sized>(&'r mut Run<'a, S>);
impl<S: Dynamics + ?Sized> Visit for Integrate<'_, '_, S> {
    type Out = Result<()>;
    fn visit<I: Integrator>(self, i: I) -> Result<()> {
        i.integrate(self.0)
    }
}

/// One integration in progress: the problem, the options, the output and the counters.
pub(crate) struct Run<'a, S: ?Sized> {
    pub(crate) system: &'a S,
    /// Number of coordinates; y has 2n components.
    pub(crate) n: usize,
    pub(crate) t0: f64,
    pub(crate) t_end: f64,
    /// Initial state (q₀, q̇₀).
    pub(crate) y0: Vec<f64>,
    pub(crate) options: &'a Options,
    pub(crate) out: Recorder,
    pub(crate) stats: Statistics,
    /// The caller's interrupt check (see [`solve_with_interrupt`]), polled at every evaluation.
    pub(crate) interrupt: Option<&'a dyn Fn(f64) -> bool>,
}

impl<S: Dynamics + ?Sized> Run<'_, S> {
    /// +1 forward in time, −1 backward.
    pub(crate) fn dir(&self) -> f64 {
        (self.t_end - self.t0).signum()
    }

    /// The number of equal fixed steps, checked against `max_steps` before the first one.
    pub(crate) fn fixed_steps(&self, dt: f64) -> Result<usize> {
        let span = (self.t_end - self.t0).abs();
        // A span that is a whole number of steps up to round-off takes that many.
        let steps = (span / dt * (1.0 - 4.0 * f64::EPSILON)).ceil().max(1.0);
        if steps > self.options.max_steps as f64 {
            return Err(Error::TooManySteps {
                t: self.t0,
                steps: self.options.max_steps,
            });
        }
        Ok(steps as usize)
    }

    /// Time of grid point `i` of `steps` equal steps, exact at both ends.
    pub(crate) fn grid_time(&self, i: usize, steps: usize) -> f64 {
        if i == steps {
            self.t_end
        } else {
            self.t0 + (self.t_end - self.t0) * (i as f64 / steps as f64)
        }
    }

    /// [`Error::Interrupted`] when the caller's interrupt check asks to stop.
    pub(crate) fn poll(&self, t: f64) -> Result<()> {
        match self.interrupt {
            Some(stop) if stop(t) => Err(Error::Interrupted { t }),
            _ => Ok(()),
        }
    }

    /// ẏ = (q̇, q̈) at (t, y), counted.
    pub(crate) fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<()> {
        self.stats.rhs_evaluations += 1;
        self.poll(t)?;
        let n = self.n;
        let (q, qd) = y.split_at(n);
        let (dq, dqd) = dy.split_at_mut(n);
        dq.copy_from_slice(qd);
        self.system.accelerations_into(t, q, qd, dqd)
    }
}

/// Integrate `system` from (q₀, q̇₀) at `span.0` to `span.1` (backwards when `span.1 <
/// span.0`) with `method`.
///
/// With `options.dt` every method takes equal fixed steps; without it the adaptive methods
/// control the local error with `rtol`/`atol` and the fixed-step ones refuse. The output
/// follows `options.output`; the statistics record the work and, for [`Method::Auto`], the
/// choice.
///
/// # Errors
/// [`Error::DimensionMismatch`] and [`Error::NonFinite`] for a bad initial state,
/// [`Error::InvalidInput`] for a bad span or option, [`Error::UnsupportedMethod`] when the
/// method cannot serve the system, and the failures of the run itself:
/// [`Error::UnstableStep`] when a fixed `dt` is beyond an explicit method's stability limit for a
/// mode of the system linearised at the start, [`Error::StepSizeTooSmall`],
/// [`Error::TooManySteps`], [`Error::NonFinite`] (with the time), [`Error::Stiffness`], [`Error::NewtonFailure`], and whatever the equations of motion report
/// ([`Error::SingularMassMatrix`]).
pub fn solve<S: Dynamics + ?Sized>(
    system: &S,
    q0: &[f64],
    qd0: &[f64],
    span: (f64, f64),
    method: Method,
    options: &Options,
) -> Result<Solution> {
    solve_inner(system, q0, qd0, span, method, options, None, true).map_err(|f| f.error)
}

/// [`solve`] that keeps what was computed when the run fails: the [`Failed`] error carries
/// the trajectory up to the last accepted step (kept as `options.output` asks, with the
/// statistics) and that last state. Failures before the first step (bad input, an unsupported
/// method, an unstable fixed `dt`) carry nothing. `interrupt` is as in [`solve_with_interrupt`].
///
/// ```
/// use lagrangian::integrators::{Method, Options, solve_partial};
/// use lagrangian::scenes::SimplePendulum;
/// let pendulum = SimplePendulum::new(1.0, 1.0, 9.81).system();
/// let options = Options { max_steps: 10, ..Options::adaptive(1e-10, 1e-12) };
/// let failed = solve_partial(&pendulum, &[0.1], &[0.0], (0.0, 100.0), Method::Dop853,
///                            &options, None).unwrap_err();
/// let partial = failed.partial.unwrap();
/// let s = &partial.stats;
/// assert_eq!(s.accepted_steps + s.rejected_steps, 10);
/// assert_eq!(partial.len(), 1 + s.accepted_steps); // the initial state and every step
/// assert_eq!(failed.last.unwrap().0, *partial.t.last().unwrap());
/// ```
///
/// # Errors
/// Those of [`solve`], as [`Failed`].
// `Failed` is a few hundred bytes (the error, the partial solution's vectors and the last
// state), returned once per run: nothing beside the integration.
#[allow(clippy::result_large_err)]
pub fn solve_partial<S: Dynamics + ?Sized>(
    system: &S,
    q0: &[f64],
    qd0: &[f64],
    span: (f64, f64),
    method: Method,
    options: &Options,
    interrupt: Option<&dyn Fn(f64) -> bool>,
) -> std::result::Result<Solution, Failed> {
    solve_inner(system, q0, qd0, span, method, options, interrupt, true)
}

/// [`solve`] with an interrupt check: `interrupt(t)` is called at every evaluation of the
/// equations of motion, and `true` stops the run with [`Error::Interrupted`]. It lets a caller
/// stop a long run (the Python binding polls Ctrl-C with it); keep it cheap.
pub fn solve_with_interrupt<S: Dynamics + ?Sized>(
    system: &S,
    q0: &[f64],
    qd0: &[f64],
    span: (f64, f64),
    method: Method,
    options: &Options,
    interrupt: &dyn Fn(f64) -> bool,
) -> Result<Solution> {
    solve_inner(
        system,
        q0,
        qd0,
        span,
        method,
        options,
        Some(interrupt),
        true,
    )
    .map_err(|f| f.error)
}

#[allow(clippy::too_many_arguments, clippy::result_large_err)]
fn solve_inner<S: Dynamics + ?Sized>(
    system: &S,
    q0: &[f64],
    qd0: &[f64],
    span: (f64, f64),
    method: Method,
    options: &Options,
    interrupt: Option<&dyn Fn(f64) -> bool>,
    check_stability: bool,
) -> std::result::Result<Solution, Failed> {
    let (t0, t_end) = span;
    let n = system.dof();
    check_state(n, t0, q0, Some(qd0))?;
    if !t_end.is_finite() {
        return Err(Failed::from(Error::NonFinite {
            what: "end time",
            t: t_end,
        }));
    }
    if t_end == t0 {
        return Err(Failed::from(Error::InvalidInput {
            what: "span",
            why: format!("t_end = t0 = {t0}: the span is empty"),
        }));
    }
    options.validate(t0, t_end)?;
    let (method, choice) = match method {
        Method::Auto => {
            let (m, why) = auto::choose(system, t0, q0, qd0, t_end, options);
            (m, Some(why))
        }
        m => (m, None),
    };
    if let Some(Err(why)) = method.visit(Fits {
        system,
        t0,
        q0,
        qd0,
    }) {
        return Err(Failed::from(Error::UnsupportedMethod {
            method: method.name(),
            why,
            fits: Method::fitting(system, t0, q0, qd0)
                .iter()
                .map(|m| m.name())
                .collect(),
        }));
    }
    options.check_method(method)?;
    if let (Some(dt), Some(true), true) = (options.dt, method.is_explicit(), check_stability) {
        stability::check(system, t0, q0, qd0, dt, method)?;
    }
    let mut y0 = q0.to_vec();
    y0.extend_from_slice(qd0);
    let dir = (t_end - t0).signum();
    let mut run = Run {
        system,
        n,
        t0,
        t_end,
        out: Recorder::new(n, options.output.clone(), dir),
        y0,
        options,
        stats: Statistics::new(method, choice),
        interrupt,
    };
    run.out.start(t0, &run.y0);
    let outcome = method
        .visit(Integrate(&mut run))
        .expect("Auto was resolved above");
    let Run { out, stats, .. } = run;
    match outcome {
        Ok(()) => Ok(out.finish(stats)),
        Err(error) => Err(out.fail(error, stats)),
    }
}
