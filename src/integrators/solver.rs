//! The solver: [`Solver`] takes a run a step at a time, [`solve`] and its variants run it to the
//! end. The top of the integrators: it checks the problem, resolves [`Method::Auto`], refuses a
//! fixed `dt` beyond an explicit method's stability limit, and drives the registry's steppers.

use super::auto;
use super::events::{Status, Stop};
use super::method::Method;
use super::options::Options;
use super::run::{Flow, Run, SegmentStepper};
use super::solution::{Failed, Solution, Statistics};
use super::step_limit;
use crate::checks::check_state;
use crate::dynamics::Dynamics;
use crate::error::{Error, Result};

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
    solve_resumed(system, q0, qd0, span, method, options, None, &[]).map_err(|f| f.error)
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
    solve_resumed(system, q0, qd0, span, method, options, interrupt, &[])
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
    solve_resumed(system, q0, qd0, span, method, options, Some(interrupt), &[]).map_err(|f| f.error)
}

/// [`solve_partial`] from where an earlier run with the same options ended on the roots of the
/// events `settling` (a terminal one, or any found within round-off of its end): their sign is
/// taken a little into the first step, as after a reset, so they do not fire again at once.
/// With no events settling it is `solve_partial`, which every `solve*` is.
#[allow(clippy::too_many_arguments, clippy::result_large_err)]
pub(crate) fn solve_resumed<'a, S: Dynamics + ?Sized>(
    system: &'a S,
    q0: &[f64],
    qd0: &[f64],
    span: (f64, f64),
    method: Method,
    options: &'a Options,
    interrupt: Option<&'a dyn Fn(f64) -> bool>,
    settling: &[usize],
) -> std::result::Result<Solution, Failed> {
    let mut solver = Solver::start(system, q0, qd0, span, method, options, interrupt, settling)?;
    solver.run.batched = true;
    // A scene's route (the Taylor method's is always its program, in lanes or alone).
    let path = |stats: &mut Statistics| {
        if stats.method != Method::Taylor {
            stats.scene_path = system.scene_path();
        }
    };
    loop {
        match solver.step() {
            Ok(StepOutcome::Finished | StepOutcome::Terminated { .. }) => {
                let mut sol = solver.solution();
                path(&mut sol.stats);
                return Ok(sol);
            }
            Ok(StepOutcome::Stepped | StepOutcome::Reset { .. }) => {}
            Err(error) => {
                let mut failed = solver.fail(error);
                if let Some(sol) = &mut failed.partial {
                    path(&mut sol.stats);
                }
                return Err(failed);
            }
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
        Self::start(system, q0, qd0, span, method, options, None, &[])
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
        options.check_error_coordinates(n)?;
        if let Some(constraints) = system.constraints() {
            constraints.check_state(t0, q0, qd0, options.projection_tolerance())?;
        }
        if let (Some(dt), Some(true)) = (options.dt, method.is_explicit()) {
            step_limit::check(system, t0, q0, qd0, dt, method)?;
        }
        let run = Run::new(
            system, q0, qd0, span, method, choice, options, interrupt, settling,
        )?;
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
                    .start(&mut *run)
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
                // A reset that leaves the constraints is brought back onto them.
                run.project(t, &mut after)?;
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
