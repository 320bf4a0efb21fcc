//! The options of [`solve`](super::solve): step control, limits and output, and their one
//! validation: every option is checked here (the Python binding only converts types), so each
//! invalid value has one message wherever it comes from.

use super::events::Event;
use super::method::Method;
use crate::error::{Error, Result};

/// Which states the [`Solution`](super::Solution) keeps.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Output {
    /// The initial state and the state after every step.
    #[default]
    Steps,
    /// The initial state, every k-th step and the final state.
    Every(usize),
    /// Only the states at these times, taken from the method's dense output (continuous
    /// extension) between steps, so the step sequence does not change. The times must lie in the
    /// span and be ordered in the direction of integration.
    Times(Vec<f64>),
    /// Only the final state (the last accepted one if the run fails): for ensembles whose runs
    /// need nothing else, so that millions of them fit in memory.
    Final,
}

/// Options of [`solve`](super::solve). Build them with [`Options::fixed`] or
/// [`Options::adaptive`] and the `with_*` methods; the defaults are Hairer's.
///
/// ```
/// use lagrangian::integrators::{Options, Output};
/// let fixed = Options::fixed(0.01).with_output(Output::Every(10));
/// let adaptive = Options::adaptive(1e-8, 1e-10).with_max_step(0.1);
/// assert_eq!(fixed.dt, Some(0.01));
/// assert_eq!(adaptive.rtol, 1e-8);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Constant step: the span is cut into N = ⌈|t_end − t0| / dt⌉ equal steps (so a symplectic
    /// method keeps one step size). `None` selects error control with `rtol` and `atol`.
    pub dt: Option<f64>,
    /// Relative tolerance of the local error (adaptive methods).
    pub rtol: f64,
    /// Absolute tolerance of the local error (adaptive methods); component i may err by
    /// `atol + rtol·|y_i|`, y = (q, q̇).
    pub atol: f64,
    /// First step size; by default estimated as in Hairer's `hinit`.
    pub initial_step: Option<f64>,
    /// Largest step size; by default the whole span.
    pub max_step: Option<f64>,
    /// Smallest step size before [`Error::StepSizeTooSmall`]; the floor is never below
    /// 10 ε |t| (below it t + h = t).
    pub min_step: f64,
    /// Most steps (accepted plus rejected) before [`Error::TooManySteps`]: one million by
    /// default, none ([`usize::MAX`]) from [`Options::fixed`], whose run takes the steps its
    /// `dt` asks for. Fixed-step runs that would need more than a budget set with
    /// [`Options::with_max_steps`] fail before the first step.
    pub max_steps: usize,
    /// Which states to keep.
    pub output: Output,
    /// Test for stiffness (explicit adaptive methods) every this many accepted steps, and at
    /// every step once a test was positive (Hairer's `NSTIFF`); `None` switches it off.
    pub stiffness_check: Option<usize>,
    /// Conditions whose sign changes are located along the run ([`Event`]); found on every
    /// step's interpolant (DOPRI5 and DOP853 screen each step on the free Hermite interpolant
    /// first and build their continuous extension only where a sign changes).
    pub events: Vec<Event>,
    /// Keep every step's interpolant: [`Solution::dense`](super::Solution::dense) gives the
    /// state anywhere in the span. Off by default: nothing extra is stored.
    pub dense: bool,
    /// Only the first k coordinates and their velocities enter the error norm of the adaptive
    /// methods (DOPRI5, DOP853, Radau IIA; the Taylor method's step-size norms); `None`: every
    /// component. A run of the variational
    /// equations ([`crate::sensitivity::Variational`]) sets it to leave the sensitivities out of error
    /// control, as CVODES's `errconS = false` does.
    pub error_coordinates: Option<usize>,
}

impl Default for Options {
    /// Adaptive steps with rtol = 1e-6, atol = 1e-9, every step kept.
    fn default() -> Self {
        Self {
            dt: None,
            rtol: 1e-6,
            atol: 1e-9,
            initial_step: None,
            max_step: None,
            min_step: 0.0,
            max_steps: 1_000_000,
            output: Output::Steps,
            stiffness_check: Some(1000),
            events: Vec::new(),
            dense: false,
            error_coordinates: None,
        }
    }
}

impl Options {
    /// Fixed steps of (at most) `dt`, as many as the span needs: no step budget unless one is
    /// set with [`Options::with_max_steps`] (as SciPy's and heyoka's fixed steps have none).
    pub fn fixed(dt: f64) -> Self {
        Self {
            dt: Some(dt),
            max_steps: usize::MAX,
            ..Self::default()
        }
    }

    /// Fixed steps of `dt` stated with their direction, as the Python API states them: a
    /// negative `dt` integrates backwards, so its sign must be that of `t_end − t0`.
    ///
    /// ```
    /// use lagrangian::integrators::Options;
    /// assert_eq!(Options::fixed_towards(-0.1, (1.0, 0.0)).unwrap().dt, Some(0.1));
    /// assert!(Options::fixed_towards(0.1, (1.0, 0.0)).is_err());
    /// ```
    pub fn fixed_towards(dt: f64, (t0, t_end): (f64, f64)) -> Result<Self> {
        if !dt.is_finite() || dt == 0.0 {
            return bad(
                "dt",
                format!("dt = {dt}: the step must be finite and non-zero"),
            );
        }
        if (t_end - t0) * dt < 0.0 {
            return bad(
                "dt",
                format!(
                    "t_end = {t_end} lies {} t0 = {t0} but dt = {dt} steps the other way: give \
                     dt the sign of t_end − t0 (a negative dt integrates backwards)",
                    if t_end < t0 { "before" } else { "after" }
                ),
            );
        }
        Ok(Self::fixed(dt.abs()))
    }

    /// Error-controlled steps with these tolerances.
    pub fn adaptive(rtol: f64, atol: f64) -> Self {
        Self {
            rtol,
            atol,
            ..Self::default()
        }
    }

    /// Set the first step size of an adaptive run.
    pub fn with_initial_step(mut self, h: f64) -> Self {
        self.initial_step = Some(h);
        self
    }

    /// Set the largest step size of an adaptive run.
    pub fn with_max_step(mut self, h: f64) -> Self {
        self.max_step = Some(h);
        self
    }

    /// Set the smallest step size of an adaptive run.
    pub fn with_min_step(mut self, h: f64) -> Self {
        self.min_step = h;
        self
    }

    /// Set the largest number of steps.
    pub fn with_max_steps(mut self, n: usize) -> Self {
        self.max_steps = n;
        self
    }

    /// Set which states are kept.
    pub fn with_output(mut self, output: Output) -> Self {
        self.output = output;
        self
    }

    /// Set (or, with `None`, switch off) the stiffness test interval.
    pub fn with_stiffness_check(mut self, every: Option<usize>) -> Self {
        self.stiffness_check = every;
        self
    }

    /// Add an event.
    pub fn with_event(mut self, event: Event) -> Self {
        self.events.push(event);
        self
    }

    /// Keep the continuous solution ([`Options::dense`]).
    pub fn with_dense(mut self, dense: bool) -> Self {
        self.dense = dense;
        self
    }

    /// Control the error of the first `k` coordinates (and their velocities) only
    /// ([`Options::error_coordinates`]).
    pub fn with_error_coordinates(mut self, k: usize) -> Self {
        self.error_coordinates = Some(k);
        self
    }

    /// The two ranges of y = (q, q̇) (length `2 n`) that the error norm reads: all of it, or the
    /// first k coordinates and their velocities ([`Options::error_coordinates`]).
    pub(crate) fn error_ranges(&self, len: usize) -> [std::ops::Range<usize>; 2] {
        let n = len / 2;
        let k = self.error_coordinates.map_or(n, |k| k.min(n));
        [0..k, n..n + k]
    }

    /// The tolerances (rtol, atol) a constrained run holds its initial state and its steps'
    /// ends to, each row's residual as a distance within atol + rtol·ℓᵢ (ℓᵢ the size of the
    /// coordinates the row reads, up to 1;
    /// [`Constrained::project_within`](crate::Constrained::project_within)): the run's own `rtol` and `atol` when the step size
    /// is controlled (the constraints hold to the accuracy asked for), each at least
    /// [`PROJECTION_TOLERANCE`](crate::PROJECTION_TOLERANCE); that tolerance for fixed steps.
    pub fn projection_tolerance(&self) -> (f64, f64) {
        projection_tolerance(self.dt.is_none().then_some((self.rtol, self.atol)))
    }

    /// Check every option against the span `t0 → t_end`.
    pub(crate) fn validate(&self, t0: f64, t_end: f64) -> Result<()> {
        if let Some(dt) = self.dt
            && !(dt.is_finite() && dt > 0.0)
        {
            return bad(
                "dt",
                format!("dt = {dt}: the fixed step must be finite and > 0"),
            );
        }
        for (what, v) in [("rtol", self.rtol), ("atol", self.atol)] {
            if !(v.is_finite() && v > 0.0) {
                return bad(
                    what,
                    format!("{what} = {v}: tolerances must be finite and > 0"),
                );
            }
        }
        for (what, v) in [
            ("initial_step", self.initial_step),
            ("max_step", self.max_step),
        ] {
            if let Some(h) = v
                && !(h.is_finite() && h > 0.0)
            {
                return bad(
                    what,
                    format!("{what} = {h}: a step size must be finite and > 0"),
                );
            }
        }
        if !(self.min_step.is_finite() && self.min_step >= 0.0) {
            return bad(
                "min_step",
                format!("min_step = {}: must be finite and ≥ 0", self.min_step),
            );
        }
        if self.max_steps == 0 {
            return bad(
                "max_steps",
                "max_steps = 0: at least one step is needed".into(),
            );
        }
        if self.error_coordinates == Some(0) {
            return bad(
                "error_coordinates",
                "error_coordinates = 0: control at least one coordinate's error, or none to \
                 control every component"
                    .into(),
            );
        }
        if self.stiffness_check == Some(0) {
            return bad(
                "stiffness_check",
                "stiffness_check = 0: give an interval ≥ 1, or none to switch the test off".into(),
            );
        }
        for event in &self.events {
            if event.terminal == Some(0) {
                return bad(
                    "event",
                    format!(
                        "event {:?} is terminal after 0 occurrences: give a count ≥ 1",
                        event.name
                    ),
                );
            }
            if event.samples > 1000 {
                return bad(
                    "event",
                    format!(
                        "event {:?} samples each step at {} points: at most 1000",
                        event.name, event.samples
                    ),
                );
            }
        }
        match &self.output {
            Output::Steps | Output::Final => {}
            Output::Every(0) => {
                return bad(
                    "output",
                    "every 0th step: keep every k-th step with k ≥ 1".into(),
                );
            }
            Output::Every(_) => {}
            Output::Times(times) => {
                let dir = (t_end - t0).signum();
                let slack = 4.0 * f64::EPSILON * t0.abs().max(t_end.abs());
                let mut previous = t0;
                for &t in times {
                    if !t.is_finite() {
                        return bad("output", format!("time {t} is not finite"));
                    }
                    if (t - t0) * dir < -slack || (t - t_end) * dir > slack {
                        return bad(
                            "output",
                            format!("time {t} lies outside the span {t0} → {t_end}"),
                        );
                    }
                    if (t - previous) * dir < 0.0 {
                        return bad(
                            "output",
                            format!(
                                "times must run in the direction {t0} → {t_end}: {t} after {previous}"
                            ),
                        );
                    }
                    previous = t;
                }
            }
        }
        Ok(())
    }

    /// Check [`Options::error_coordinates`] against a system of `n` coordinates.
    pub(crate) fn check_error_coordinates(&self, n: usize) -> Result<()> {
        match self.error_coordinates {
            Some(k) if k > n => bad(
                "error_coordinates",
                format!("error_coordinates = {k}, but the system has {n} coordinates"),
            ),
            _ => Ok(()),
        }
    }

    /// Check that `method` can run with these options: a fixed-step method needs `dt`.
    pub(crate) fn check_method(&self, method: Method) -> Result<()> {
        if self.dt.is_none() && method.is_adaptive() == Some(false) {
            return bad(
                "dt",
                format!(
                    "{} takes fixed steps: pass dt (Options::fixed(dt) in Rust, dt=… in Python)",
                    method.name()
                ),
            );
        }
        Ok(())
    }
}

/// The error of an invalid option.
fn bad<T>(what: &'static str, why: String) -> Result<T> {
    Err(Error::InvalidInput { what, why })
}

/// [`Options::projection_tolerance`] from the run's (rtol, atol) when its step size is
/// controlled, `None` for fixed steps: the one statement of the rule, also for the Python
/// binding's checks before a run.
pub(crate) fn projection_tolerance(controlled: Option<(f64, f64)>) -> (f64, f64) {
    let floor = crate::constrained::PROJECTION_TOLERANCE;
    controlled.map_or((floor, floor), |(rtol, atol)| {
        (rtol.max(floor), atol.max(floor))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn why(r: Result<impl std::fmt::Debug>) -> String {
        r.unwrap_err().to_string()
    }

    #[test]
    fn fixed_towards_sign_of_the_span() {
        assert_eq!(
            Options::fixed_towards(0.1, (0.0, 1.0)).unwrap().dt,
            Some(0.1)
        );
        assert_eq!(
            Options::fixed_towards(-0.1, (0.0, -1.0)).unwrap().dt,
            Some(0.1)
        );
        assert!(why(Options::fixed_towards(-0.1, (0.0, 1.0))).contains("after t0"));
        assert!(why(Options::fixed_towards(0.1, (0.0, -1.0))).contains("before t0"));
        assert!(why(Options::fixed_towards(0.0, (0.0, 1.0))).contains("dt = 0"));
        assert!(why(Options::fixed_towards(f64::NAN, (0.0, 1.0))).contains("dt = NaN"));
    }

    #[test]
    fn validate_one_message_per_option() {
        let check = |o: Options| why(o.validate(0.0, 1.0));
        assert_eq!(
            check(Options::adaptive(0.0, 1e-9)),
            "invalid rtol: rtol = 0: tolerances must be finite and > 0"
        );
        assert_eq!(
            check(Options::adaptive(1e-6, -1.0)),
            "invalid atol: atol = -1: tolerances must be finite and > 0"
        );
        assert_eq!(
            check(Options::default().with_max_steps(0)),
            "invalid max_steps: max_steps = 0: at least one step is needed"
        );
        assert!(check(Options::default().with_output(Output::Every(0))).contains("k ≥ 1"));
    }

    #[test]
    fn check_method_fixed_step_needs_dt() {
        let adaptive = Options::default();
        assert!(why(adaptive.check_method(Method::Rk4)).contains("rk4 takes fixed steps: pass dt"));
        assert!(adaptive.check_method(Method::Dop853).is_ok());
        assert!(Options::fixed(0.1).check_method(Method::Rk4).is_ok());
    }
}
