//! Events: the sign changes of conditions g(t, q, q̇) along a run, located on each step's
//! interpolant, with what they do (record, stop the run, or reset the state and go on).
//!
//! Every accepted step is searched, for every method: g is evaluated at the step's end and at
//! [`Event::samples`] interior points of the method's dense output (or, for the fixed-step and
//! symplectic methods, the quintic Hermite polynomial through the step's ends), so that a
//! condition which changes sign and back inside one step is still seen, as robust codes do. A
//! sign change between two samples is refined by Brent's method on the interpolant to a few
//! units of round-off in t. The continuous extension of DOPRI5 and DOP853 costs three or four
//! evaluations per step, so their steps are sampled first on the free quintic Hermite
//! interpolant through the step's ends; only a step where g changes sign is searched again on
//! the method's own interpolant, which then locates the root. An event is a change between
//! non-zero values: g touching zero and
//! returning is none, and a condition that is exactly zero at the start takes its sign from the
//! first non-zero sample. After a reset the events at its time sit on their roots; each takes
//! its sign from a sample a thousandth into the next step, so the root it sits on is not found
//! again and the next crossing counts unless it comes within that thousandth. Events at one time are all
//! recorded; of their resets only the first event's (in the order given) is applied.

use std::fmt;
use std::sync::Arc;

use super::dense::Interpolant;
use crate::error::{Error, Result};

/// Where, as a fraction of the first step after a reset, an event that sat on its root takes
/// its sign again.
const SETTLE: f64 = 1e-3;

/// Which sign changes of a condition count.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Direction {
    /// Both.
    #[default]
    Either,
    /// From negative to positive.
    Rising,
    /// From positive to negative.
    Falling,
}

impl Direction {
    /// −1 falling, 0 either, +1 rising (SciPy's and the Python API's convention).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for any other number.
    pub fn from_sign(sign: i64) -> Result<Self> {
        match sign {
            0 => Ok(Self::Either),
            1 => Ok(Self::Rising),
            -1 => Ok(Self::Falling),
            other => Err(Error::InvalidInput {
                what: "event direction",
                why: format!("direction = {other}: use +1 (rising), −1 (falling) or 0 (either)"),
            }),
        }
    }

    fn admits(self, new_sign: f64) -> bool {
        match self {
            Self::Either => true,
            Self::Rising => new_sign > 0.0,
            Self::Falling => new_sign < 0.0,
        }
    }
}

/// The condition g(t, q, q̇) of an [`Event`].
pub type Condition = dyn Fn(f64, &[f64], &[f64]) -> f64 + Send + Sync;
/// The reset of an [`Event`]: overwrites (q, q̇) at the event time t.
pub type Reset = dyn Fn(f64, &mut [f64], &mut [f64]) + Send + Sync;

/// A condition whose sign changes are recorded, and optionally stop the run or reset its state.
///
/// ```
/// use lagrangian::integrators::{Event, Method, Options, solve};
/// use lagrangian::scenes::SimplePendulum;
/// let pendulum = SimplePendulum::new(1.0, 1.0, 9.81).system();
/// // Released at θ = 0.1: θ falls through zero after a quarter period, ≈ (π/2)√(l/g).
/// let options = Options::adaptive(1e-10, 1e-12)
///     .with_event(Event::new("theta = 0", |_t, q, _qd| q[0]).falling().terminal(1));
/// let sol = solve(&pendulum, &[0.1], &[0.0], (0.0, 10.0), Method::Dop853, &options).unwrap();
/// let t_quarter = sol.events[0].t[0];
/// assert!((t_quarter - std::f64::consts::FRAC_PI_2 / 9.81_f64.sqrt()).abs() < 1e-3);
/// assert_eq!(*sol.t.last().unwrap(), t_quarter); // the run stopped there
/// ```
#[derive(Clone)]
pub struct Event {
    /// The name used in messages and [`Status`].
    pub name: String,
    /// g(t, q, q̇).
    pub condition: Arc<Condition>,
    /// Which sign changes count.
    pub direction: Direction,
    /// Stop the run at the k-th occurrence (`Some(k)`, k ≥ 1); `None` never stops.
    pub terminal: Option<usize>,
    /// Overwrite the state at each occurrence and go on from there (an impact law).
    pub reset: Option<Arc<Reset>>,
    /// Interior points of each step at which g is sampled (besides the step's end), so that a
    /// condition that changes sign twice inside one step is still seen.
    pub samples: usize,
}

impl Event {
    /// Interior samples per step unless [`Event::with_samples`] says otherwise.
    pub const SAMPLES: usize = 4;

    /// An event at every sign change of `condition`, recorded and nothing else.
    pub fn new(
        name: impl Into<String>,
        condition: impl Fn(f64, &[f64], &[f64]) -> f64 + Send + Sync + 'static,
    ) -> Self {
        Self {
            name: name.into(),
            condition: Arc::new(condition),
            direction: Direction::Either,
            terminal: None,
            reset: None,
            samples: Self::SAMPLES,
        }
    }

    /// Only changes from negative to positive.
    pub fn rising(self) -> Self {
        self.with_direction(Direction::Rising)
    }

    /// Only changes from positive to negative.
    pub fn falling(self) -> Self {
        self.with_direction(Direction::Falling)
    }

    /// Set which changes count.
    pub fn with_direction(mut self, direction: Direction) -> Self {
        self.direction = direction;
        self
    }

    /// Stop the run at the `count`-th occurrence.
    pub fn terminal(mut self, count: usize) -> Self {
        self.terminal = Some(count);
        self
    }

    /// At each occurrence overwrite (q, q̇) with `reset(t, q, q̇)` and go on from there. A
    /// terminal occurrence ends the run before its reset.
    pub fn with_reset(
        mut self,
        reset: impl Fn(f64, &mut [f64], &mut [f64]) + Send + Sync + 'static,
    ) -> Self {
        self.reset = Some(Arc::new(reset));
        self
    }

    /// Sample g at `samples` interior points of each step.
    pub fn with_samples(mut self, samples: usize) -> Self {
        self.samples = samples;
        self
    }
}

impl fmt::Debug for Event {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Event")
            .field("name", &self.name)
            .field("direction", &self.direction)
            .field("terminal", &self.terminal)
            .field("reset", &self.reset.is_some())
            .field("samples", &self.samples)
            .finish_non_exhaustive()
    }
}

impl PartialEq for Event {
    /// The same functions (by identity) and settings.
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
            && Arc::ptr_eq(&self.condition, &other.condition)
            && self.direction == other.direction
            && self.terminal == other.terminal
            && match (&self.reset, &other.reset) {
                (None, None) => true,
                (Some(a), Some(b)) => Arc::ptr_eq(a, b),
                _ => false,
            }
            && self.samples == other.samples
    }
}

/// The occurrences of one event in a run, in order: times and the states there (before any
/// reset). States are row-major, `dof` per occurrence.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Occurrences {
    /// Event times.
    pub t: Vec<f64>,
    /// Coordinates at each time.
    pub q: Vec<f64>,
    /// Velocities at each time.
    pub qd: Vec<f64>,
}

/// Why a run ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Status {
    /// It reached the end of the span.
    Finished,
    /// A terminal event stopped it.
    Terminated {
        /// Index of the event in [`Options::events`](super::Options::events).
        event: usize,
        /// Its name.
        name: String,
        /// When.
        t: f64,
    },
    /// The run failed (the partial solution of a [`Failed`](super::Failed) run).
    Failed,
    /// The run was ended by [`Solver::solution`](super::Solver::solution) at `t`, before the end
    /// of the span.
    Unfinished {
        /// The time it had reached.
        t: f64,
    },
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Finished => f.write_str("reached t_end"),
            Self::Terminated { name, t, .. } => write!(f, "terminal event {name} at t = {t}"),
            Self::Failed => f.write_str("failed"),
            Self::Unfinished { t } => write!(f, "stopped at t = {t} before t_end"),
        }
    }
}

/// Where the run must stop inside a step: a terminal event, or a reset to apply.
pub(crate) struct Stop {
    pub(crate) t: f64,
    /// The state at `t`, before any reset.
    pub(crate) y: Vec<f64>,
    /// The event that stops the run (terminal, or whose reset applies).
    pub(crate) event: usize,
    pub(crate) terminal: bool,
    /// Every event with a root at `t`, `event` first: they all sit on their roots there.
    pub(crate) fired: Vec<usize>,
}

/// The state of every event along a run.
pub(crate) struct Tracker {
    events: Vec<Event>,
    n: usize,
    /// g at the start of the current step.
    value: Vec<f64>,
    /// The sign of the last non-zero sample; 0 while unknown.
    sign: Vec<f64>,
    /// Whether the event sat on its root when a reset was applied: then its sign is taken
    /// from a sample a thousandth into the next step ([`SETTLE`]), so that the root it sits on
    /// is not found again and the next crossing counts however soon it comes after.
    settle: Vec<bool>,
    pub(crate) found: Vec<Occurrences>,
    y: Vec<f64>,
    /// Work space: one event's samples (θ, g) over a step, and each event's end of step.
    points: Vec<(f64, f64)>,
    ends: Vec<(f64, f64)>,
}

impl Tracker {
    pub(crate) fn new(events: &[Event], n: usize) -> Self {
        Self {
            events: events.to_vec(),
            n,
            value: vec![0.0; events.len()],
            sign: vec![0.0; events.len()],
            settle: vec![false; events.len()],
            found: vec![Occurrences::default(); events.len()],
            // Nothing allocated for a run without events (a short run's fixed cost).
            y: if events.is_empty() {
                Vec::new()
            } else {
                vec![0.0; 2 * n]
            },
            points: Vec::new(),
            ends: Vec::with_capacity(events.len()),
        }
    }

    /// Whether there is anything to look for.
    pub(crate) fn active(&self) -> bool {
        !self.events.is_empty()
    }

    fn g(&self, i: usize, t: f64, y: &[f64]) -> Result<f64> {
        let (q, qd) = y.split_at(self.n);
        let g = (self.events[i].condition)(t, q, qd);
        if g.is_finite() {
            Ok(g)
        } else {
            Err(Error::NonFinite {
                what: "event condition",
                t,
            })
        }
    }

    /// Take the signs at (t, y), the start of the run.
    pub(crate) fn start(&mut self, t: f64, y: &[f64]) -> Result<()> {
        for i in 0..self.events.len() {
            let g = self.g(i, t, y)?;
            self.value[i] = g;
            self.sign[i] = sign(g);
            self.settle[i] = false;
        }
        Ok(())
    }

    /// After a reset at (t, y), the new state: the signs there, except for the events `fired`
    /// at t, which sit on their roots: they take their sign a little into the next step.
    pub(crate) fn restart(&mut self, t: f64, y: &[f64], fired: &[usize]) -> Result<()> {
        self.start(t, y)?;
        for &i in fired {
            self.sign[i] = 0.0;
            self.settle[i] = true;
        }
        Ok(())
    }

    /// Event `i`'s samples (θ, g) over the step (t, t_new] into `self.points`, the first being
    /// where the search starts (the step's start, or [`SETTLE`] into the step for an event
    /// that sat on its root at a reset); whether the sign starts afresh there.
    fn sample(
        &mut self,
        i: usize,
        t: f64,
        t_new: f64,
        y_new: &[f64],
        step: &Interpolant<'_>,
    ) -> Result<bool> {
        let h = t_new - t;
        let samples = self.events[i].samples;
        let mut points = std::mem::take(&mut self.points);
        points.clear();
        let fresh = self.settle[i];
        if fresh {
            points.push((SETTLE, self.at(i, t, h, SETTLE, step)?));
        } else {
            points.push((0.0, self.value[i]));
        }
        let first = points[0].0;
        for j in 1..=samples {
            let theta = j as f64 / (samples + 1) as f64;
            if theta > first {
                points.push((theta, self.at(i, t, h, theta, step)?));
            }
        }
        points.push((1.0, self.g(i, t_new, y_new)?));
        self.points = points;
        Ok(fresh)
    }

    /// Whether no event occurs in the step (t, t_new], sampled on `step`, which may be a
    /// cheaper interpolant than the method's own: then the step's signs are taken and nothing
    /// else is needed. Otherwise nothing changes, and the step is to be searched with
    /// [`Tracker::scan`] on the method's interpolant.
    pub(crate) fn quiet(
        &mut self,
        t: f64,
        t_new: f64,
        y_new: &[f64],
        step: &Interpolant<'_>,
    ) -> Result<bool> {
        let mut ends = std::mem::take(&mut self.ends);
        ends.clear();
        for i in 0..self.events.len() {
            let fresh = self.sample(i, t, t_new, y_new, step)?;
            let mut sign_ref = if fresh { 0.0 } else { self.sign[i] };
            for &(_, g) in &self.points {
                if g != 0.0 {
                    let s = sign(g);
                    if sign_ref != 0.0 && s != sign_ref && self.events[i].direction.admits(s) {
                        self.ends = ends;
                        return Ok(false);
                    }
                    sign_ref = s;
                }
            }
            let g_end = self.points.last().map_or(0.0, |p| p.1);
            ends.push((sign_ref, g_end));
        }
        for (i, &(s, g)) in ends.iter().enumerate() {
            self.sign[i] = s;
            self.value[i] = g;
            self.settle[i] = false;
        }
        self.ends = ends;
        Ok(true)
    }

    /// Search the step (t, t_new] whose interpolant is `step`: record the occurrences up to the
    /// first one that stops the run, and return that one.
    pub(crate) fn scan(
        &mut self,
        t: f64,
        t_new: f64,
        y_new: &[f64],
        step: &Interpolant<'_>,
    ) -> Result<Option<Stop>> {
        let h = t_new - t;
        // (θ of the root, event) for every sign change in the step.
        let mut roots: Vec<(f64, usize)> = Vec::new();
        for i in 0..self.events.len() {
            let fresh = self.sample(i, t, t_new, y_new, step)?;
            let points = std::mem::take(&mut self.points);
            let mut sign_ref = if fresh { 0.0 } else { self.sign[i] };
            for (j, &(theta_b, g_b)) in points.iter().enumerate() {
                if g_b == 0.0 {
                    continue;
                }
                let s = sign(g_b);
                if j > 0 && sign_ref != 0.0 && s != sign_ref && self.events[i].direction.admits(s) {
                    let (theta_a, g_a) = points[j - 1];
                    roots.push((
                        self.refine(i, t, h, (theta_a, g_a), (theta_b, g_b), step)?,
                        i,
                    ));
                }
                sign_ref = s;
            }
            self.sign[i] = sign_ref;
            self.value[i] = points.last().map_or(0.0, |p| p.1);
            self.settle[i] = false;
            self.points = points;
        }
        roots.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Roots this close (in θ) are at one time: Brent's resolution.
        let same = 8.0 * f64::EPSILON * (t.abs() / h.abs()).max(1.0);
        for (k, &(theta, i)) in roots.iter().enumerate() {
            let (t_root, y) = self.state_at(t, t_new, y_new, theta, step);
            self.record(i, t_root, &y);
            let event = &self.events[i];
            let terminal = event.terminal.is_some_and(|c| self.found[i].t.len() >= c);
            if terminal || event.reset.is_some() {
                // Every other event with a root at this time is recorded too: it sits on its
                // root when the run stops or resets.
                let mut fired = vec![i];
                for &(other, j) in roots[k + 1..].iter().take_while(|r| r.0 - theta <= same) {
                    let (t_other, y_other) = self.state_at(t, t_new, y_new, other, step);
                    self.record(j, t_other, &y_other);
                    fired.push(j);
                }
                return Ok(Some(Stop {
                    t: t_root,
                    y,
                    event: i,
                    terminal,
                    fired,
                }));
            }
        }
        Ok(None)
    }

    /// The time and state at θ of the step.
    fn state_at(
        &self,
        t: f64,
        t_new: f64,
        y_new: &[f64],
        theta: f64,
        step: &Interpolant<'_>,
    ) -> (f64, Vec<f64>) {
        if theta == 1.0 {
            (t_new, y_new.to_vec())
        } else {
            let t_root = t + theta * (t_new - t);
            let mut y = vec![0.0; 2 * self.n];
            step.eval(t_root, &mut y);
            (t_root, y)
        }
    }

    fn record(&mut self, i: usize, t: f64, y: &[f64]) {
        let found = &mut self.found[i];
        found.t.push(t);
        found.q.extend_from_slice(&y[..self.n]);
        found.qd.extend_from_slice(&y[self.n..]);
    }

    /// Apply event `i`'s reset to y = (q, q̇) at t.
    pub(crate) fn reset(&self, i: usize, t: f64, y: &mut [f64]) -> Result<()> {
        if let Some(reset) = &self.events[i].reset {
            let (q, qd) = y.split_at_mut(self.n);
            reset(t, q, qd);
            if !y.iter().all(|v| v.is_finite()) {
                return Err(Error::NonFinite {
                    what: "state after an event's reset",
                    t,
                });
            }
        }
        Ok(())
    }

    pub(crate) fn name(&self, i: usize) -> &str {
        &self.events[i].name
    }

    /// g of event `i` at t + θh on the interpolant.
    fn at(&mut self, i: usize, t: f64, h: f64, theta: f64, step: &Interpolant<'_>) -> Result<f64> {
        let time = t + theta * h;
        let mut y = std::mem::take(&mut self.y);
        step.eval(time, &mut y);
        let g = self.g(i, time, &y);
        self.y = y;
        g
    }

    /// The root of g in (θa, θb], where g changes sign, by Brent's method to a few units of
    /// round-off in t.
    fn refine(
        &mut self,
        i: usize,
        t: f64,
        h: f64,
        (a, fa): (f64, f64),
        (b, fb): (f64, f64),
        step: &Interpolant<'_>,
    ) -> Result<f64> {
        if fa == 0.0 {
            return Ok(a);
        }
        // θ resolution: the spacing of floating-point times near t.
        let xtol = 2.0 * f64::EPSILON * (t.abs() / h.abs()).max(1.0);
        brent(a, fa, b, fb, xtol, |theta| self.at(i, t, h, theta, step))
    }
}

fn sign(g: f64) -> f64 {
    if g > 0.0 {
        1.0
    } else if g < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// Brent's root finder (zeroin) on [a, b] with f(a)·f(b) < 0, to |b − a| ≤ 2·xtol around the
/// root (at most 100 iterations; each halves the bracket at worst every other step).
fn brent(
    mut a: f64,
    mut fa: f64,
    mut b: f64,
    mut fb: f64,
    xtol: f64,
    mut f: impl FnMut(f64) -> Result<f64>,
) -> Result<f64> {
    let (mut c, mut fc) = (a, fa);
    let mut d = b - a;
    let mut e = d;
    for _ in 0..100 {
        if fb.signum() == fc.signum() {
            (c, fc) = (a, fa);
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            (a, fa) = (b, fb);
            (b, fb) = (c, fc);
            (c, fc) = (a, fa);
        }
        let tol = 2.0 * f64::EPSILON * b.abs() + 0.5 * xtol;
        let m = 0.5 * (c - b);
        if m.abs() <= tol || fb == 0.0 {
            return Ok(b);
        }
        if e.abs() >= tol && fa.abs() > fb.abs() {
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * m * s;
                q = 1.0 - s;
            } else {
                let qq = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * m * qq * (qq - r) - (b - a) * (r - 1.0));
                q = (qq - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            } else {
                p = -p;
            }
            if 2.0 * p < (3.0 * m * q - (tol * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = m;
                e = m;
            }
        } else {
            d = m;
            e = m;
        }
        (a, fa) = (b, fb);
        b += if d.abs() > tol { d } else { tol.copysign(m) };
        fb = f(b)?;
    }
    Ok(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brent_finds_roots_to_round_off() {
        let root = brent(0.0, -2.0, 2.0, 2.0, 1e-16, |x| Ok(x * x - 2.0)).unwrap();
        assert!((root - 2f64.sqrt()).abs() <= 4.0 * f64::EPSILON);
        let root = brent(0.0, 1.0, 3.0, -0.98999, 1e-16, |x| Ok(x.cos())).unwrap();
        assert!((root - std::f64::consts::FRAC_PI_2).abs() <= 4.0 * f64::EPSILON);
    }

    #[test]
    fn direction_from_sign() {
        assert_eq!(Direction::from_sign(-1).unwrap(), Direction::Falling);
        assert_eq!(Direction::from_sign(1).unwrap(), Direction::Rising);
        assert!(Direction::from_sign(2).is_err());
        assert!(Direction::Rising.admits(1.0) && !Direction::Rising.admits(-1.0));
    }
}
