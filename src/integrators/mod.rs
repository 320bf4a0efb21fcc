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
//! A constrained system ([`Constrained`](crate::Constrained), whose
//! [`Dynamics::constraints`](crate::Dynamics::constraints) is set) integrates its index-1
//! accelerations with the Runge–Kutta methods and radau5, each accepted step projected back onto
//! the constraints (positions, then velocities, to the run's `rtol`, or 10⁻¹² at a fixed `dt`):
//! no drift over any run length; [`Statistics::projections`] and
//! [`Statistics::constraint_residual`] say what it took. With holonomic rows only,
//! `stormer_verlet` and `yoshida4/6/8` (on a separable system) run as compositions of RATTLE
//! steps and `midpoint` takes a constrained variational step: each step ends on the constraints
//! to round-off without a projection, and the map is symplectic on the constraint manifold, so
//! the energy error stays bounded. The initial state must satisfy the constraints
//! ([`Error::InconsistentState`](crate::Error::InconsistentState); see
//! [`Constrained::project`](crate::Constrained::project)); the other methods (`blanes_moan4`,
//! `gauss4/6`, `taylor`, and the symplectic ones on velocity rows) refuse a constrained system
//! with [`Error::UnsupportedMethod`].
//!
//! Events ([`Event`], in [`Options::events`]) are sign changes of conditions g(t, q, q̇), found
//! with every method on each step's interpolant and refined to round-off; a terminal event ends
//! the run, a reset changes the state and the run goes on ([`Solution::events`],
//! [`Solution::status`]). [`Options::dense`] keeps every step's interpolant as a callable
//! [`Dense`] solution. [`Solver`] takes a run a step at a time; [`solve`] is that solver in a
//! loop.
//!
//! A new method is one file implementing the crate's internal `Integrator` trait (`run.rs`; its
//! `start` gives a stepper that takes one accepted step at a time and hands it to the run), its
//! variant and name in `method.rs`, and one arm in the registry (`registry.rs`).
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
//!
//! [`Dynamics::accelerations_into`]: crate::Dynamics::accelerations_into
//! [`Error::UnsupportedMethod`]: crate::Error::UnsupportedMethod
//! [`Error::NewtonFailure`]: crate::Error::NewtonFailure
//! [`Error::StepSizeTooSmall`]: crate::Error::StepSizeTooSmall
//! [`Error::TooManySteps`]: crate::Error::TooManySteps
//! [`Error::NonFinite`]: crate::Error::NonFinite
//! [`Error::Stiffness`]: crate::Error::Stiffness
//! [`Error::UnstableStep`]: crate::Error::UnstableStep

// The files, one way (each uses only those listed before it): the pieces of a run (`method`,
// `dense`, `events`, `options`, `solution`, `tableau`), the step interface (`run`), the methods
// (`runge_kutta`, `symplectic`, `implicit` with `variational`, `gauss` and `radau`, `taylor`),
// the `registry` of the methods, the tests on the linearization (`stiffness`, `step_limit`), the
// choice of `auto`, and the `solver` with `ensemble` on top.
mod auto;
#[cfg(feature = "parallel")]
mod batch;
mod dense;
#[cfg(feature = "parallel")]
mod ensemble;
mod events;
mod gauss;
mod implicit;
mod method;
mod options;
mod radau;
mod rattle;
mod registry;
mod run;
mod runge_kutta;
mod solution;
mod solver;
mod step_limit;
mod stiffness;
mod symplectic;
mod tableau;
mod taylor;
mod variational;

pub use dense::{Dense, DenseParts};
#[cfg(feature = "parallel")]
pub use ensemble::{RunResult, Systems, solve_many};
pub use events::{Condition, Direction, Event, Occurrences, Reset, Status};
pub use method::Method;
#[cfg(feature = "python")]
pub(crate) use options::projection_tolerance;
pub use options::{Options, Output};
pub use solution::{Failed, Solution, Statistics};
#[cfg(feature = "python")]
pub(crate) use solver::solve_resumed;
pub use solver::{Solver, StepOutcome, solve, solve_partial, solve_with_interrupt};
pub use symplectic::SymplecticTableau;
pub use tableau::{Controller, DenseOutput, ErrorEstimate, StiffnessTest, Tableau};
