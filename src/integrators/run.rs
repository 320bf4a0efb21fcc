//! The step interface: what every method implements ([`Integrator`], [`SegmentStepper`]) and the
//! run it steps ([`Run`]): the problem, the options, the output, the events, the counters.
//! Below the methods' files; the registry and the solver sit above them.

use super::dense::{Dense, Interpolant};
use super::events::{Stop, Tracker};
use super::method::Method;
use super::options::Options;
use super::solution::{Recorder, Statistics};
use crate::dynamics::Dynamics;
use crate::error::{Error, Result};

/// What every method implements. The registry dispatches on [`Method`] to a value of a type
/// implementing it.
pub(crate) trait Integrator {
    /// Order of convergence.
    fn order(&self) -> usize;

    /// Whether the step size is controlled by an error estimate when no `dt` is given.
    fn adaptive(&self) -> bool;

    /// Whether a step is explicit: then a fixed `dt` has a stability limit, checked before the
    /// run (see `step_limit.rs`).
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

/// `Err(why)` for a constrained system ([`Dynamics::constraints`]) when the method's step does
/// not hold constraints: `how` says what the step would need.
pub(crate) fn unconstrained_only<S: Dynamics + ?Sized>(
    system: &S,
    how: &str,
) -> std::result::Result<(), String> {
    match system.constraints() {
        Some(_) => Err(format!(
            "the model is constrained, and {how}; the Runge–Kutta methods and radau5 project \
             each step back onto the constraints, and with holonomic rows only \
             stormer_verlet and yoshida4/6/8 (RATTLE, on a separable system) and midpoint end \
             each step on them"
        )),
        None => Ok(()),
    }
}

/// One method integrating one segment, a step at a time: what [`Solver::step`](super::Solver::step)
/// drives.
pub(crate) trait SegmentStepper<S: Dynamics + ?Sized> {
    /// Take one accepted step (rejected attempts are retried inside) and hand it to
    /// [`Run::accept`]; before it, a stepper may take the [`Run::quiet_steps`] and only count
    /// them.
    fn step(&mut self, run: &mut Run<'_, S>) -> Result<Flow>;
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
    /// The caller's interrupt check (see [`solve_with_interrupt`](super::solve_with_interrupt)),
    /// polled at every evaluation.
    pub(crate) interrupt: Option<&'a dyn Fn(f64) -> bool>,
    /// The events' search state and occurrences.
    pub(crate) events: Tracker,
    /// The continuous solution, when [`Options::dense`] asks for it.
    pub(crate) dense: Option<Dense>,
    /// Where an event stopped the current segment.
    pub(crate) stop: Option<Stop>,
    /// A state buffer for the recorder's dense output.
    pub(crate) buf: Vec<f64>,
    /// Whether a stepper may take several steps per call ([`Run::quiet_steps`]): in a whole
    /// run, not when [`Solver::step`](super::Solver::step) hands them out one at a time.
    pub(crate) batched: bool,
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

/// `out = v`, as moves for up to eight components rather than a call of `memcpy`: the copies of
/// a small system's step are of a few numbers.
#[inline(always)]
pub(crate) fn copy(v: &[f64], out: &mut [f64]) {
    macro_rules! fixed {
        ($($m:literal)*) => {
            match out.len() {
                $($m => out.copy_from_slice(&v[..$m]),)*
                _ => out.copy_from_slice(v),
            }
        };
    }
    fixed!(1 2 3 4 5 6 7 8)
}

/// `y += a x`, over arrays of up to eight components known at compile time: one vector store
/// per pair rather than a store per component, which a following vector load of `y` (a small
/// system's force reading q) can take directly (scalar stores made it wait ≈ 12 cycles).
#[inline(always)]
pub(crate) fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    #[inline(always)]
    fn fixed<const M: usize>(a: f64, x: &[f64], y: &mut [f64]) {
        let x: &[f64; M] = x[..M].try_into().expect("M components");
        let y: &mut [f64; M] = y.try_into().expect("M components");
        *y = std::array::from_fn(|i| y[i] + a * x[i]);
    }
    match y.len() {
        1 => fixed::<1>(a, x, y),
        2 => fixed::<2>(a, x, y),
        3 => fixed::<3>(a, x, y),
        4 => fixed::<4>(a, x, y),
        6 => fixed::<6>(a, x, y),
        8 => fixed::<8>(a, x, y),
        _ => {
            for (y, x) in y.iter_mut().zip(x) {
                *y += a * x;
            }
        }
    }
}

impl<'a, S: Dynamics + ?Sized> Run<'a, S> {
    /// A run of `method` over `span` standing at (q₀, q̇₀), recorded and with its events
    /// started; the caller has checked the problem. `choice` is why [`Method::Auto`] chose
    /// `method`, `settling` as in `solve_resumed`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        system: &'a S,
        q0: &[f64],
        qd0: &[f64],
        (t0, t_end): (f64, f64),
        method: Method,
        choice: Option<String>,
        options: &'a Options,
        interrupt: Option<&'a dyn Fn(f64) -> bool>,
        settling: &[usize],
    ) -> Result<Self> {
        let n = system.dof();
        let mut y0 = q0.to_vec();
        y0.extend_from_slice(qd0);
        let dir = (t_end - t0).signum();
        let mut run = Self {
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
        Ok(run)
    }

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

    /// Bring an accepted step's end state y (at `t`) back onto the system's constraints, if it
    /// has any (no drift: Hairer, Lubich & Wanner §IV.4's projection method), and record the
    /// residual left; whether y moved, so that a method keeping f(t, y) evaluates it anew.
    pub(crate) fn project(&mut self, t: f64, y: &mut [f64]) -> Result<bool> {
        let Some(constraints) = self.system.constraints() else {
            return Ok(false);
        };
        let tol = self.options.projection_tolerance();
        let (q, qd) = y.split_at_mut(self.n);
        let moved = constraints.project_in_place(t, q, qd, tol)?;
        self.stats.projections += usize::from(moved);
        let residual = constraints.worst_residual(t, q, qd)?;
        self.stats.constraint_residual = self.stats.constraint_residual.max(residual);
        Ok(moved)
    }

    /// ẏ = (q̇, q̈) at (t, y), counted. Inline: a small system's right-hand side is then compiled
    /// into the stepper's loop, as into a hand-written one.
    #[inline(always)]
    pub(crate) fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<()> {
        self.stats.rhs_evaluations += 1;
        self.poll(t)?;
        let n = self.n;
        let (q, qd) = y.split_at(n);
        let (dq, dqd) = dy.split_at_mut(n);
        copy(qd, dq);
        self.system.accelerations_into(t, q, qd, dqd)
    }

    /// [`Run::rhs`] of a state of `M` components known at compile time (`M = 0`: any number):
    /// q̇ copied as one move of its known length.
    #[inline(always)]
    pub(crate) fn rhs_n<const M: usize>(
        &mut self,
        t: f64,
        y: &[f64],
        dy: &mut [f64],
    ) -> Result<()> {
        if M == 0 || 2 * self.n != M {
            return self.rhs(t, y, dy);
        }
        self.stats.rhs_evaluations += 1;
        self.poll(t)?;
        let (q, qd) = y[..M].split_at(M / 2);
        let (dq, dqd) = dy[..M].split_at_mut(M / 2);
        dq.copy_from_slice(qd);
        self.system.accelerations_into(t, q, qd, dqd)
    }
}
