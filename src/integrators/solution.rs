//! What [`solve`](super::solve) returns: the trajectory and the work it took; what
//! [`solve_partial`](super::solve_partial) returns when a run fails ([`Failed`]); and the
//! recorder that fills the trajectory according to [`Output`].

use super::dense::Dense;
use super::events::{Occurrences, Status};
use super::method::Method;
use super::options::Output;
use crate::error::Error;

/// The work a run took. Counters that a method family does not use stay 0 (the Jacobian,
/// factorization and Newton counters are for implicit methods; a splitting method factors its
/// constant mass matrix once).
#[derive(Debug, Clone, PartialEq)]
pub struct Statistics {
    /// The method that ran (what [`Method::Auto`] chose, otherwise the one asked for).
    pub method: Method,
    /// Why [`Method::Auto`] chose `method`; `None` when the method was given.
    pub choice: Option<String>,
    /// Steps accepted.
    pub accepted_steps: usize,
    /// Steps rejected by the error test (or because a trial stage was not finite).
    pub rejected_steps: usize,
    /// Evaluations of the right-hand side: accelerations q̈ for Runge–Kutta methods, forces
    /// M⁻¹(Q″ − ∂U/∂q) for splitting methods.
    pub rhs_evaluations: usize,
    /// Jacobian evaluations.
    pub jacobian_evaluations: usize,
    /// Matrix factorizations.
    pub factorizations: usize,
    /// Newton iterations that failed to converge.
    pub newton_failures: usize,
    /// Accepted steps whose end state a constrained system's projection moved back onto the
    /// constraints ([`Dynamics::constraints`](crate::Dynamics::constraints)).
    pub projections: usize,
    /// The largest absolute constraint residual (g, ġ and the velocity rows) at the end of an
    /// accepted step, after its projection; 0 for a system without constraints.
    pub constraint_residual: f64,
    /// How a ready-made scene's accelerations were computed and why, when the run went through
    /// [`FastPath`](crate::trace::FastPath) (`None` otherwise): its
    /// [`route`](crate::trace::FastPath::route).
    pub scene_path: Option<String>,
}

/// A counter of [`Statistics`]: its name and how to read it.
type Counter = (&'static str, fn(&Statistics) -> usize);

impl Statistics {
    /// The counters by name, in one order: the Python statistics dict and an ensemble's
    /// counter columns are both made from this table.
    pub const COUNTERS: [Counter; 7] = [
        ("accepted_steps", |s| s.accepted_steps),
        ("rejected_steps", |s| s.rejected_steps),
        ("rhs_evaluations", |s| s.rhs_evaluations),
        ("jacobian_evaluations", |s| s.jacobian_evaluations),
        ("factorizations", |s| s.factorizations),
        ("newton_failures", |s| s.newton_failures),
        ("projections", |s| s.projections),
    ];

    pub(crate) fn new(method: Method, choice: Option<String>) -> Self {
        Self {
            method,
            choice,
            accepted_steps: 0,
            rejected_steps: 0,
            rhs_evaluations: 0,
            jacobian_evaluations: 0,
            factorizations: 0,
            newton_failures: 0,
            projections: 0,
            constraint_residual: 0.0,
            scene_path: None,
        }
    }
}

/// A trajectory (t, q, q̇) with the statistics of the run that made it. States are stored
/// row-major: row i of `q` is `q[i * dof..(i + 1) * dof]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// Number of coordinates.
    pub dof: usize,
    /// Output times, in the direction of integration.
    pub t: Vec<f64>,
    /// Coordinates, one row of `dof` per time.
    pub q: Vec<f64>,
    /// Velocities, one row of `dof` per time.
    pub qd: Vec<f64>,
    /// The work it took.
    pub stats: Statistics,
    /// The occurrences of each event of [`Options::events`](super::Options::events), in order.
    pub events: Vec<Occurrences>,
    /// Why the run ended.
    pub status: Status,
    /// The continuous solution, with [`Options::dense`](super::Options::dense).
    pub dense: Option<Dense>,
}

impl Solution {
    /// Number of output times.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether no state was kept (possible only with an empty [`Output::Times`]).
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Coordinates at output `i`.
    pub fn q_at(&self, i: usize) -> &[f64] {
        &self.q[i * self.dof..(i + 1) * self.dof]
    }

    /// Velocities at output `i`.
    pub fn qd_at(&self, i: usize) -> &[f64] {
        &self.qd[i * self.dof..(i + 1) * self.dof]
    }

    /// The last kept state (t, q, q̇), if any.
    pub fn last(&self) -> Option<(f64, &[f64], &[f64])> {
        let i = self.len().checked_sub(1)?;
        Some((self.t[i], self.q_at(i), self.qd_at(i)))
    }
}

/// A run that failed, with what it had computed: returned by
/// [`solve_partial`](super::solve_partial).
#[derive(Debug, Clone, PartialEq)]
pub struct Failed {
    /// Why it failed; [`solve`](super::solve) returns only this.
    pub error: Error,
    /// The trajectory up to the last accepted step, kept as [`Output`] asks, and the statistics
    /// of the work done. With [`Output::Steps`] or [`Output::Every`] its last row is the last
    /// accepted state, with [`Output::Final`] its only row; with [`Output::Times`] it holds the requested times reached. `None` when
    /// the failure came before the first step (bad input, an unsupported method, a fixed `dt`
    /// beyond the stability limit).
    pub partial: Option<Solution>,
    /// The last accepted state (t, q, q̇), from which the failing step started; `None` with
    /// `partial`.
    pub last: Option<(f64, Vec<f64>, Vec<f64>)>,
}

impl std::fmt::Display for Failed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.error.fmt(f)
    }
}

impl std::error::Error for Failed {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.error)
    }
}

impl From<Error> for Failed {
    /// A failure before the first step: nothing computed.
    fn from(error: Error) -> Self {
        Self {
            error,
            partial: None,
            last: None,
        }
    }
}

/// Fills a [`Solution`] as the steps come, following [`Output`].
pub(crate) struct Recorder {
    n: usize,
    output: Output,
    /// +1 forward in time, −1 backward.
    dir: f64,
    /// Index of the next requested time ([`Output::Times`]).
    next: usize,
    steps: usize,
    pub(crate) t: Vec<f64>,
    pub(crate) q: Vec<f64>,
    pub(crate) qd: Vec<f64>,
    /// The last accepted time and state y = (q, q̇), kept for a failure.
    last_t: f64,
    last_y: Vec<f64>,
}

impl Recorder {
    pub(crate) fn new(n: usize, output: Output, dir: f64) -> Self {
        Self {
            n,
            output,
            dir,
            next: 0,
            steps: 0,
            t: Vec::new(),
            q: Vec::new(),
            qd: Vec::new(),
            last_t: f64::NAN,
            last_y: Vec::new(),
        }
    }

    fn push(&mut self, t: f64, q: &[f64], qd: &[f64]) {
        self.t.push(t);
        self.q.extend_from_slice(q);
        self.qd.extend_from_slice(qd);
    }

    /// The initial state.
    pub(crate) fn start(&mut self, t0: f64, y: &[f64]) {
        self.last_t = t0;
        self.last_y = y.to_vec();
        let (q, qd) = y.split_at(self.n);
        if let Output::Times(times) = &self.output {
            let at_start = times
                .iter()
                .take_while(|&&t| (t - t0) * self.dir <= 0.0)
                .count();
            self.next = at_start;
            for _ in 0..at_start {
                self.push(t0, q, qd);
            }
        } else if self.output != Output::Final {
            self.push(t0, q, qd);
        }
    }

    /// Whether a requested time lies in the step that ends at `t_new`.
    pub(crate) fn wants_dense(&self, t_new: f64) -> bool {
        match &self.output {
            Output::Times(times) => {
                self.next < times.len() && (times[self.next] - t_new) * self.dir <= 0.0
            }
            _ => false,
        }
    }

    /// Emit every requested time up to `t_new`, with `eval(t, y)` writing y = (q, q̇) from the
    /// step's dense output. `y_new` is used as is at `t_new` itself.
    pub(crate) fn dense(
        &mut self,
        t_new: f64,
        y_new: &[f64],
        y_buf: &mut [f64],
        mut eval: impl FnMut(f64, &mut [f64]),
    ) {
        let Self {
            n,
            output,
            dir,
            next,
            t: ts,
            q: qs,
            qd: qds,
            ..
        } = self;
        let Output::Times(times) = output else {
            return;
        };
        while *next < times.len() && (times[*next] - t_new) * *dir <= 0.0 {
            let t = times[*next];
            *next += 1;
            if t == t_new {
                y_buf.copy_from_slice(y_new);
            } else {
                eval(t, y_buf);
            }
            let (q, qd) = y_buf.split_at(*n);
            ts.push(t);
            qs.extend_from_slice(q);
            qds.extend_from_slice(qd);
        }
    }

    /// A step has ended at (t, y); `last` marks the end of the span.
    pub(crate) fn step(&mut self, t: f64, y: &[f64], last: bool) {
        self.steps += 1;
        self.last_t = t;
        self.last_y.copy_from_slice(y);
        let keep = match self.output {
            Output::Steps => true,
            Output::Every(k) => last || self.steps.is_multiple_of(k),
            Output::Final => last,
            Output::Times(_) => false,
        };
        if keep {
            let (q, qd) = y.split_at(self.n);
            self.push(t, q, qd);
        }
    }

    /// Steps to come that keep nothing: before the next one [`Output::Every`] keeps, or every
    /// step but the last with [`Output::Final`] (a step that ends the run is kept regardless).
    /// None with [`Output::Steps`] and [`Output::Times`] (whose steps are kept or searched for
    /// the requested times).
    pub(crate) fn unkept_steps(&self) -> usize {
        match self.output {
            Output::Every(k) => k - 1 - self.steps % k,
            Output::Final => usize::MAX,
            Output::Steps | Output::Times(_) => 0,
        }
    }

    /// Steps that keep nothing ([`Recorder::unkept_steps`]) and are not the last, counted but
    /// not recorded as the last accepted state: [`Recorder::reached`] records the last when the run
    /// fails before the next recorded step.
    pub(crate) fn skip(&mut self, steps: usize) {
        self.steps += steps;
    }

    /// The last accepted time and state y = (q, q̇), after steps [`Recorder::skip`] counted.
    pub(crate) fn reached(&mut self, t: f64, y: &[f64]) {
        self.last_t = t;
        self.last_y.copy_from_slice(y);
    }

    /// The last accepted time and state y = (q, q̇) (after a reset, the state after it).
    pub(crate) fn last(&self) -> (f64, &[f64]) {
        (self.last_t, &self.last_y)
    }

    /// What a run that failed with `error` had computed: with [`Output::Steps`],
    /// [`Output::Every`] or [`Output::Final`] the last accepted state ends the trajectory (as
    /// it ends a finished one).
    pub(crate) fn fail(mut self, error: Error, stats: Statistics) -> Failed {
        let (t, y) = (self.last_t, std::mem::take(&mut self.last_y));
        let (q, qd) = y.split_at(self.n);
        if !matches!(self.output, Output::Times(_)) && self.t.last() != Some(&t) {
            self.push(t, q, qd);
        }
        let last = Some((t, q.to_vec(), qd.to_vec()));
        Failed {
            error,
            partial: Some(self.finish(stats)),
            last,
        }
    }

    /// A reset at t took the state from `before` to `after`: with [`Output::Steps`] or
    /// [`Output::Every`] both are kept, so the jump shows in the trajectory.
    pub(crate) fn jump(&mut self, t: f64, before: &[f64], after: &[f64]) {
        if !matches!(self.output, Output::Times(_)) {
            let (q, qd) = before.split_at(self.n);
            self.push(t, q, qd);
            let (q, qd) = after.split_at(self.n);
            self.push(t, q, qd);
        }
        self.last_t = t;
        self.last_y.copy_from_slice(after);
    }

    pub(crate) fn finish(self, stats: Statistics) -> Solution {
        Solution {
            dof: self.n,
            t: self.t,
            q: self.q,
            qd: self.qd,
            stats,
            events: Vec::new(),
            status: Status::Finished,
            dense: None,
        }
    }
}
