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
//! Events ([`Event`], in [`Options::events`]) are sign changes of conditions g(t, q, q̇), found
//! with every method on each step's interpolant and refined to round-off; a terminal event ends
//! the run, a reset changes the state and the run goes on ([`Solution::events`],
//! [`Solution::status`]). [`Options::dense`] keeps every step's interpolant as a callable
//! [`Dense`] solution. [`Solver`] takes a run a step at a time; [`solve`] is that solver in a
//! loop.
//!
//! A new method is one file implementing the crate's internal `Integrator` trait (its `start`
//! gives a stepper that takes one accepted step at a time and hands it to the run) and one line
//! in its registry (`src/integrators/mod.rs`).
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
mod events;
mod gauss;
mod implicit;
mod options;
mod radau;
mod runge_kutta;
mod solution;
mod stability;
mod stiffness;
mod symplectic;
mod tableau;
mod taylor;
mod variational;

pub use dense::{Dense, DenseParts};
#[cfg(feature = "parallel")]
pub use ensemble::{RunResult, Systems, solve_many};
pub use events::{Condition, Direction, Event, Occurrences, Reset, Status};
pub use options::{Options, Output};
pub use solution::{Failed, Solution, Statistics};
pub use symplectic::SymplecticTableau;
pub use tableau::{Controller, DenseOutput, ErrorEstimate, StiffnessTest, Tableau};

use crate::dynamics::{Dynamics, check_state};
use crate::error::{Error, Result};
use dense::Interpolant;
use events::{Stop, Tracker};
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

    /// Set up the integration of the run's current segment (from `run.t0`, `run.y0` to
    /// `run.t_end`), to be taken a step at a time.
    fn start<S: Dynamics + ?Sized>(
        self,
        run: &mut Run<'_, S>,
    ) -> Result<Box<dyn SegmentStepper<S>>>;
}

/// One method integrating one segment, a step at a time: what [`Solver::step`] drives.
pub(crate) trait SegmentStepper<S: Dynamics + ?Sized> {
    /// Take one accepted step (rejected attempts are retried inside) and hand it to
    /// [`Run::accept`]; before it, a stepper may take the [`Run::quiet_steps`] and only count
    /// them.
    fn step(&mut self, run: &mut Run<'_, S>) -> Result<Flow>;
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
            ///    when the system is stiff;
            /// 3. else, with tolerances only and where the stiffness test ran, `taylor` for a
            ///    model stated as an analytic expression graph where its cost, estimated from
            ///    the sizes of the model's programs and the tolerance, is below DOP853's: small
            ///    smooth systems from about 1e-9 down (the double pendulum from about 1e-12);
            ///    not the N-link chains, whose series of M cost too much per step;
            /// 4. else `dop853` (adaptive, or at the fixed `dt`).
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
    Rk4 = "rk4" => ExplicitRk::new(&runge_kutta::RK4),
    /// Dormand–Prince 5(4) with step control, dense output and stiffness test (Hairer's `dopri5`).
    Dopri5 = "dopri5" => ExplicitRk::new(&runge_kutta::DOPRI5),
    /// Dormand–Prince 8(5,3) with step control, dense output and stiffness test (Hairer's `dop853`).
    Dop853 = "dop853" => ExplicitRk::new(&runge_kutta::DOP853),
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
    /// The Taylor method (Jorba & Zou) on the model's expression graph: order and step from the
    /// tolerance and the series' radius of convergence; models stated as expressions only, with
    /// no |x| or sign(x) of the state. `Auto` chooses it where its cost, estimated from the
    /// sizes of the model's programs and the tolerance, is below DOP853's (`auto.rs`): small
    /// smooth models from about 1e-9 down, not the N-link chains, where a step's p²/2 graph
    /// evaluations make it 1.9–11× slower than DOP853.
    Taylor = "taylor" => taylor::Taylor,
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

    /// Whether this method can integrate `system` from this state ([`Method::Auto`] always
    /// can).
    ///
    /// # Errors
    /// [`Error::UnsupportedMethod`]: why not, and the methods that can.
    pub fn check_fits<S: Dynamics + ?Sized>(
        self,
        system: &S,
        t0: f64,
        q0: &[f64],
        qd0: &[f64],
    ) -> Result<()> {
        match self.visit(Fits {
            system,
            t0,
            q0,
            qd0,
        }) {
            Some(Err(why)) => Err(Error::UnsupportedMethod {
                method: self.name(),
                why,
                fits: Method::fitting(system, t0, q0, qd0)
                    .iter()
                    .map(|m| m.name())
                    .collect(),
            }),
            _ => Ok(()),
        }
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

struct Start<'r, 'a, S: ?Sized>(&'r mut Run<'a, S>);
impl<S: Dynamics + ?Sized> Visit for Start<'_, '_, S> {
    type Out = Result<Box<dyn SegmentStepper<S>>>;
    fn visit<I: Integrator>(self, i: I) -> Self::Out {
        i.start(self.0)
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
    /// The events' search state and occurrences.
    events: Tracker,
    /// The continuous solution, when [`Options::dense`] asks for it.
    dense: Option<Dense>,
    /// Where an event stopped the current segment.
    stop: Option<Stop>,
    /// A state buffer for the recorder's dense output.
    buf: Vec<f64>,
    /// Whether a stepper may take several steps per call ([`Run::quiet_steps`]): in a whole
    /// run, not when [`Solver::step`] hands them out one at a time.
    batched: bool,
}

/// What follows an accepted step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[must_use]
pub(crate) enum Flow {
    /// Take the next step.
    Continue,
    /// An event stopped the segment inside the step (terminal, or a reset to apply).
    Stop,
    /// The step reached the end of the span.
    End,
}

impl<S: Dynamics + ?Sized> Run<'_, S> {
    /// +1 forward in time, −1 backward.
    pub(crate) fn dir(&self) -> f64 {
        (self.t_end - self.t0).signum()
    }

    /// The number of equal fixed steps, checked against `max_steps` before the first one
    /// ([`Options::fixed`] sets no budget: the steps asked for are taken).
    pub(crate) fn fixed_steps(&self, dt: f64) -> Result<usize> {
        let span = (self.t_end - self.t0).abs();
        // A span that is a whole number of steps up to round-off takes that many.
        let steps = (span / dt * (1.0 - 4.0 * f64::EPSILON)).ceil().max(1.0);
        // Steps of earlier segments (before an event's reset) count against the budget too.
        let taken = self.stats.accepted_steps + self.stats.rejected_steps;
        if steps + taken as f64 > self.options.max_steps as f64 {
            return Err(Error::TooManySteps {
                t: self.t0,
                steps: self.options.max_steps,
                needed: Some((steps as usize).saturating_add(taken)),
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

    /// How many steps a stepper may take before the next one it hands to [`Run::accept`]
    /// (counting each with [`Recorder::skip`]): steps that nothing watches (no event searched,
    /// no interpolant kept, no output recorded) in a whole run ([`Run::batched`]).
    pub(crate) fn quiet_steps(&self) -> usize {
        if !self.batched || self.events.active() || self.dense.is_some() {
            return 0;
        }
        self.out.unkept_steps()
    }

    /// Whether the step ending at `t_new` needs its interpolant: a requested output time lies
    /// in it, events are searched, or the continuous solution is kept.
    pub(crate) fn needs_interpolant(&self, t_new: f64) -> bool {
        self.events.active() || self.dense.is_some() || self.out.wants_dense(t_new)
    }

    /// For a method whose own interpolant costs evaluations (a Runge–Kutta continuous
    /// extension): when only events need it, first sample the step on the cheap interpolant
    /// `rough` (quintic Hermite through the step's ends). `Some(flow)` when no event occurs in
    /// the step, which is then accepted; `None` when the method's own interpolant is needed.
    pub(crate) fn accept_if_quiet(
        &mut self,
        t: f64,
        t_new: f64,
        y_new: &[f64],
        last: bool,
        rough: &Interpolant<'_>,
    ) -> Result<Option<Flow>> {
        if !self.events.active() || self.dense.is_some() || self.out.wants_dense(t_new) {
            return Ok(None);
        }
        if !self.events.quiet(t, t_new, y_new, rough)? {
            return Ok(None);
        }
        self.out.step(t_new, y_new, last);
        Ok(Some(if last { Flow::End } else { Flow::Continue }))
    }

    /// A step from t to `t_new` was accepted, ending at `y_new`; `step` is its interpolant when
    /// [`Run::needs_interpolant`] said so. Searches the events, emits the requested output times
    /// and the step, keeps the interpolant for the continuous solution.
    pub(crate) fn accept(
        &mut self,
        t: f64,
        t_new: f64,
        y_new: &[f64],
        last: bool,
        step: Option<&Interpolant<'_>>,
    ) -> Result<Flow> {
        let done = if last { Flow::End } else { Flow::Continue };
        // An empty step (t_new = t by rounding at the end of a span) holds nothing to search.
        let step = step.filter(|_| t_new != t);
        let Some(step) = step else {
            self.out.step(t_new, y_new, last);
            return Ok(done);
        };
        let stop = if self.events.active() {
            self.events.scan(t, t_new, y_new, step)?
        } else {
            None
        };
        let (t_end, y_end) = stop.as_ref().map_or((t_new, y_new), |s| (s.t, &s.y[..]));
        self.out
            .dense(t_end, y_end, &mut self.buf, |ti, out| step.eval(ti, out));
        if let Some(dense) = &mut self.dense {
            dense.push(step, t_end);
        }
        match stop {
            None => {
                self.out.step(t_new, y_new, last);
                Ok(done)
            }
            Some(stop) => {
                self.stop = Some(stop);
                Ok(Flow::Stop)
            }
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
    solve_inner(system, q0, qd0, span, method, options, None, true, &[]).map_err(|f| f.error)
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
    solve_inner(system, q0, qd0, span, method, options, interrupt, true, &[])
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
        &[],
    )
    .map_err(|f| f.error)
}

/// [`solve_partial`] from where an earlier run with the same options ended on the roots of the
/// events `settling` (a terminal one, or any found within round-off of its end): their sign is
/// taken a little into the first step, as after a reset, so they do not fire again at once.
#[allow(clippy::too_many_arguments, clippy::result_large_err)]
pub(crate) fn solve_resumed<S: Dynamics + ?Sized>(
    system: &S,
    q0: &[f64],
    qd0: &[f64],
    span: (f64, f64),
    method: Method,
    options: &Options,
    interrupt: Option<&dyn Fn(f64) -> bool>,
    settling: &[usize],
) -> std::result::Result<Solution, Failed> {
    solve_inner(
        system, q0, qd0, span, method, options, interrupt, true, settling,
    )
}

#[allow(clippy::too_many_arguments, clippy::result_large_err)]
fn solve_inner<'a, S: Dynamics + ?Sized>(
    system: &'a S,
    q0: &[f64],
    qd0: &[f64],
    span: (f64, f64),
    method: Method,
    options: &'a Options,
    interrupt: Option<&'a dyn Fn(f64) -> bool>,
    check_stability: bool,
    settling: &[usize],
) -> std::result::Result<Solution, Failed> {
    let mut solver = Solver::start(
        system,
        q0,
        qd0,
        span,
        method,
        options,
        interrupt,
        check_stability,
        settling,
    )?;
    solver.run.batched = true;
    loop {
        match solver.step() {
            Ok(StepOutcome::Finished | StepOutcome::Terminated { .. }) => {
                return Ok(solver.solution());
            }
            Ok(StepOutcome::Stepped | StepOutcome::Reset { .. }) => {}
            Err(error) => return Err(solver.fail(error)),
        }
    }
}

/// Why [`Solver::step`] returned.
#[derive(Debug, Clone, PartialEq)]
pub enum StepOutcome {
    /// A step was taken; the run goes on.
    Stepped,
    /// A step was taken and an event's reset changed the state at `t`; the run goes on from
    /// the new state.
    Reset {
        /// Index of the event in [`Options::events`].
        event: usize,
        /// When.
        t: f64,
    },
    /// The run has reached the end of the span.
    Finished,
    /// A terminal event has stopped the run at `t`.
    Terminated {
        /// Index of the event in [`Options::events`].
        event: usize,
        /// When.
        t: f64,
    },
}

/// A run taken a step at a time, as diffsol's solvers are: [`solve`] is this in a loop.
///
/// [`Solver::step`] takes one accepted step of the method (rejected attempts are retried inside)
/// and says why it returned; between steps the current state, the statistics and what was
/// recorded so far can be read, and [`Solver::solution`] ends the run with what it has.
///
/// ```
/// use lagrangian::integrators::{Event, Method, Options, Solver, StepOutcome};
/// use lagrangian::scenes::SimplePendulum;
/// let pendulum = SimplePendulum::new(1.0, 1.0, 9.81).system();
/// let options = Options::adaptive(1e-10, 1e-12)
///     .with_event(Event::new("theta = 0", |_t, q, _qd| q[0]).terminal(1));
/// let mut solver = Solver::new(&pendulum, &[0.1], &[0.0], (0.0, 10.0), Method::Dop853, &options)
///     .unwrap();
/// let mut steps = 0;
/// let t_stop = loop {
///     match solver.step().unwrap() {
///         StepOutcome::Stepped | StepOutcome::Reset { .. } => steps += 1,
///         StepOutcome::Terminated { t, .. } => break t,
///         StepOutcome::Finished => unreachable!("θ crosses zero first"),
///     }
///     assert!(solver.t() < 1.0); // the state after each step
/// };
/// assert_eq!(solver.t(), t_stop);
/// let sol = solver.solution();
/// assert_eq!(sol.stats.accepted_steps, steps + 1);
/// ```
pub struct Solver<'a, S: Dynamics + ?Sized> {
    run: Run<'a, S>,
    method: Method,
    /// The current segment's stepper; `None` until the segment's first step.
    stepper: Option<Box<dyn SegmentStepper<S>>>,
    /// How the run ended (the last outcome of [`Solver::step`]), once it has.
    end: Option<Result<StepOutcome>>,
}

impl<'a, S: Dynamics + ?Sized> Solver<'a, S> {
    /// Check the problem and the options as [`solve`] does, choose the method for
    /// [`Method::Auto`], and stand at the initial state, ready for [`Solver::step`].
    ///
    /// # Errors
    /// Those of [`solve`] that come before the first step.
    pub fn new(
        system: &'a S,
        q0: &[f64],
        qd0: &[f64],
        span: (f64, f64),
        method: Method,
        options: &'a Options,
    ) -> Result<Self> {
        Self::start(system, q0, qd0, span, method, options, None, true, &[])
    }

    #[allow(clippy::too_many_arguments)]
    fn start(
        system: &'a S,
        q0: &[f64],
        qd0: &[f64],
        span: (f64, f64),
        method: Method,
        options: &'a Options,
        interrupt: Option<&'a dyn Fn(f64) -> bool>,
        check_stability: bool,
        settling: &[usize],
    ) -> Result<Self> {
        let (t0, t_end) = span;
        let n = system.dof();
        check_state(n, t0, q0, Some(qd0))?;
        if !t_end.is_finite() {
            return Err(Error::NonFinite {
                what: "end time",
                t: t_end,
            });
        }
        if t_end == t0 {
            return Err(Error::InvalidInput {
                what: "span",
                why: format!("t_end = t0 = {t0}: the span is empty"),
            });
        }
        options.validate(t0, t_end)?;
        let (method, choice) = match method {
            Method::Auto => {
                let (m, why) = auto::choose(system, t0, q0, qd0, t_end, options);
                (m, Some(why))
            }
            m => (m, None),
        };
        method.check_fits(system, t0, q0, qd0)?;
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
            events: Tracker::new(&options.events, n),
            dense: options.dense.then(|| Dense::new(2 * n, dir)),
            stop: None,
            buf: vec![0.0; 2 * n],
            batched: false,
        };
        run.out.start(t0, &run.y0);
        run.events.restart(t0, &run.y0, settling)?;
        Ok(Self {
            run,
            method,
            stepper: None,
            end: None,
        })
    }

    /// Take one step. After the run has ended (or failed) every call returns how it ended.
    ///
    /// # Errors
    /// The failures of the run that [`solve`] reports; the solver keeps what was computed
    /// before ([`Solver::solution`]).
    pub fn step(&mut self) -> Result<StepOutcome> {
        if let Some(end) = &self.end {
            return end.clone();
        }
        let outcome = self.advance();
        if matches!(
            outcome,
            Err(_) | Ok(StepOutcome::Finished | StepOutcome::Terminated { .. })
        ) {
            self.end = Some(outcome.clone());
        }
        outcome
    }

    fn advance(&mut self) -> Result<StepOutcome> {
        let run = &mut self.run;
        let stepper = match &mut self.stepper {
            Some(stepper) => stepper,
            None => self.stepper.insert(
                self.method
                    .visit(Start(&mut *run))
                    .expect("Auto was resolved in Solver::new")?,
            ),
        };
        match stepper.step(run)? {
            Flow::Continue => Ok(StepOutcome::Stepped),
            Flow::End => Ok(StepOutcome::Finished),
            Flow::Stop => {
                let Stop {
                    t,
                    y,
                    event,
                    terminal,
                    fired,
                } = run.stop.take().expect("a stopped step leaves its stop");
                if terminal {
                    run.out.step(t, &y, true);
                    return Ok(StepOutcome::Terminated { event, t });
                }
                // A reset: the next segment starts from the new state, with a new stepper.
                self.stepper = None;
                let mut after = y.clone();
                run.events.reset(event, t, &mut after)?;
                run.out.jump(t, &y, &after);
                let dir = run.dir();
                // A reset within round-off of the end ends the run: no step fits after it.
                if (run.t_end - t) * dir <= 10.0 * f64::EPSILON * t.abs().max(run.t_end.abs()) {
                    let t_end = run.t_end;
                    let mut buf = std::mem::take(&mut run.buf);
                    run.out.dense(t_end, &after, &mut buf, |_, out| {
                        out.copy_from_slice(&after)
                    });
                    run.buf = buf;
                    return Ok(StepOutcome::Finished);
                }
                let attempts = run.stats.accepted_steps + run.stats.rejected_steps;
                if attempts >= run.options.max_steps {
                    return Err(Error::TooManySteps {
                        t,
                        steps: attempts,
                        needed: None,
                    });
                }
                run.events.restart(t, &after, &fired)?;
                run.t0 = t;
                run.y0 = after;
                Ok(StepOutcome::Reset { event, t })
            }
        }
    }

    /// The time of the current state.
    pub fn t(&self) -> f64 {
        self.run.out.last().0
    }

    /// The current state (q, q̇): after a reset, the state after it.
    pub fn state(&self) -> (&[f64], &[f64]) {
        self.run.out.last().1.split_at(self.run.n)
    }

    /// The work so far.
    pub fn stats(&self) -> &Statistics {
        &self.run.stats
    }

    /// End the run here: the trajectory recorded so far (as [`Options::output`] asks), the
    /// events found, the continuous solution, and how the run ended ([`Status::Unfinished`]
    /// before the end of the span, [`Status::Failed`] after an error).
    pub fn solution(self) -> Solution {
        let status = match self.end {
            Some(Ok(StepOutcome::Finished)) => Status::Finished,
            Some(Ok(StepOutcome::Terminated { event, t })) => Status::Terminated {
                event,
                name: self.run.events.name(event).to_owned(),
                t,
            },
            Some(Err(_)) => Status::Failed,
            _ => Status::Unfinished { t: self.t() },
        };
        let Run {
            out,
            stats,
            events,
            dense,
            ..
        } = self.run;
        Solution {
            status,
            events: events.found,
            dense,
            ..out.finish(stats)
        }
    }

    /// The run failed with `error`: what it had computed.
    fn fail(self, error: Error) -> Failed {
        let Run {
            out,
            stats,
            events,
            dense,
            ..
        } = self.run;
        let mut failed = out.fail(error, stats);
        failed.partial = failed.partial.map(|sol| Solution {
            events: events.found,
            dense,
            status: Status::Failed,
            ..sol
        });
        failed
    }
}
