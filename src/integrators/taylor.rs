//! The Taylor method (Jorba & Zou 2005) on a model's expression graph.
//!
//! Each step expands the motion through the current state to order p by series arithmetic on
//! the graph ([`crate::tape::TaylorProgram`]: M₀ q̈ₖ = fₖ − Σ Mⱼ q̈ₖ₋ⱼ, no symbolic inverse of
//! M) and sums the series at the step h, adding the increment to the state with Kahan's
//! compensated summation (the rounding of the state does not pile up over long runs).
//! Following Jorba & Zou, the order comes from the tolerance, p = ⌈−ln ε / 2 + 1⌉, and the
//! step from the last two coefficients, h = ρ / e² · e^(−0.7/(p−1)) with ρ =
//! min((1/‖xₚ₋₁‖)^(1/(p−1)), (1/‖xₚ‖)^(1/p)): the coefficients of an analytic solution decay
//! like ρ⁻ᵏ, so the truncation error is about ε. ε = min(rtol, atol), and each component's
//! coefficients are measured against its own tolerance atol + rtol |yᵢ| (Jorba and Zou take
//! one norm of the whole state, absolute or relative to ‖y‖∞: a coordinate that grows, such as
//! an angle that winds, would loosen every other component's tolerance). The step is
//! [`Expansion::step`]: once a model's expansion is compiled unrolled, the whole of it —
//! expansion, step size and new state — is one call of machine code, and the steps nothing
//! watches go in rows of such steps, one call a row (`Expansion::steps`). Steps are never
//! rejected.
//! The step's polynomial is its dense output, exact to the method's order anywhere in the
//! step; events are found on it.
//!
//! The method needs the model's graph: it serves models stated as expressions (Python's
//! `lg.Model`, `tape::EomProgram`), not Rust types implementing the energy traits.

use super::dense::Interpolant;
use super::run::{Flow, Integrator, Run, SegmentStepper};
use crate::derived::eom_program::EomFunction;
use crate::dynamics::Dynamics;
use crate::error::{Error, Result};
#[cfg(feature = "jit")]
use crate::taylor::RowEnd;
use crate::taylor::{Expansion, StepRule};

/// Jorba & Zou's order for the tolerance ε, p = ⌈−ln ε / 2 + 1⌉, capped where double precision
/// has nothing left to gain (p = 40 is ε ≈ 1e-34).
pub(super) fn order_for(eps: f64) -> usize {
    ((-eps.ln() / 2.0 + 1.0).ceil() as usize).clamp(2, 40)
}

/// The Taylor method.
pub(crate) struct Taylor;

impl Integrator for Taylor {
    fn order(&self) -> usize {
        // The order follows the tolerance; this is the order at the default tolerance 1e-6
        // (p = ⌈ln 10⁶ / 2 + 1⌉).
        8
    }

    fn adaptive(&self) -> bool {
        true
    }

    fn explicit(&self) -> bool {
        true
    }

    fn fits<S: Dynamics + ?Sized>(
        &self,
        system: &S,
        _t0: f64,
        _q0: &[f64],
        _qd0: &[f64],
    ) -> std::result::Result<(), String> {
        match system.taylor_program() {
            Err(why) => Err(why),
            Ok(p) if !EomFunction::of(p).taylor().0.is_analytic() => {
                Err("the model takes |x| or sign(x) of \
                 the state, which have no Taylor series across x = 0 (a step would run past \
                 the kink unseen): use dop853, whose error control finds it"
                    .into())
            }
            Ok(_) => Ok(()),
        }
    }

    fn start<S: Dynamics + ?Sized>(
        self,
        run: &mut Run<'_, S>,
    ) -> Result<Box<dyn SegmentStepper<S>>> {
        if run.options.dt.is_some() {
            return Err(Error::InvalidInput {
                what: "dt",
                why: "taylor chooses its steps from the tolerances: give rtol and atol, not dt"
                    .into(),
            });
        }
        let eom = run
            .system
            .taylor_program()
            .map_err(|why| Error::InvalidInput {
                what: "method",
                why,
            })?;
        let (program, params) = EomFunction::of(eom).taylor();
        let (rtol, atol) = (run.options.rtol, run.options.atol);
        // The order for the tighter of the two tolerances, fixed for the run.
        let eps = rtol.min(atol);
        let order = order_for(eps);
        let span = (run.t_end - run.t0).abs();
        Ok(Box::new(TaylorStepper {
            expansion: program.expansion(params, order),
            rule: StepRule {
                rtol,
                atol,
                h_max: run.options.max_step.unwrap_or(span).min(span),
                min_step: run.options.min_step,
                t_end: run.t_end,
                dir: run.dir(),
                controlled: run
                    .options
                    .error_coordinates
                    .map_or(f64::INFINITY, |k| k as f64),
            },
            planned: false,
            t: run.t0,
            y: run.y0.clone(),
            y_new: vec![0.0; run.y0.len()],
            lost: vec![0.0; run.y0.len()],
        }))
    }
}

/// Where a Taylor run stands between steps.
struct TaylorStepper {
    expansion: Expansion,
    rule: StepRule,
    /// Whether the run's length was estimated (after its first step, [`Expansion::plan`]).
    planned: bool,
    t: f64,
    y: Vec<f64>,
    y_new: Vec<f64>,
    /// What rounding took off the state in the last step's sum, added back in the next one
    /// (Kahan's compensated summation of the increments): the state's rounding errors do not
    /// pile up step after step.
    lost: Vec<f64>,
}

/// Quiet steps a row of compiled steps takes at most (`Expansion::steps`): the run's
/// interrupt check is polled between rows, every few milliseconds at most.
#[cfg(feature = "jit")]
const ROW: usize = 64;

impl TaylorStepper {
    /// Steps the run may still take from here, after its interrupt check.
    fn allowed<S: Dynamics + ?Sized>(&self, run: &Run<'_, S>) -> Result<usize> {
        let attempts = run.stats.accepted_steps + run.stats.rejected_steps;
        if attempts >= run.options.max_steps {
            return Err(Error::TooManySteps {
                t: self.t,
                steps: attempts,
                needed: None,
            });
        }
        run.poll(self.t)?;
        Ok(run.options.max_steps - attempts)
    }

    /// `steps` taken, counted.
    fn count<S: Dynamics + ?Sized>(&self, run: &mut Run<'_, S>, steps: usize) {
        // One pass of the recurrences per order, each about a graph evaluation or more.
        run.stats.rhs_evaluations += steps * self.expansion.order();
        run.stats.accepted_steps += steps;
    }

    /// The next step from (t, y) into `y_new`, counted: where it ends, and whether the run
    /// does. With `quiet` steps that nothing watches to go, those before it may first be taken
    /// in a row of compiled code, which moves (t, y) (and counts them, and takes them off
    /// `quiet`): `None` when the row ended without a next step to hand on.
    fn take<S: Dynamics + ?Sized>(
        &mut self,
        run: &mut Run<'_, S>,
        quiet: &mut usize,
    ) -> Result<Option<(f64, bool)>> {
        let allowed = self.allowed(run)?;
        #[cfg(feature = "jit")]
        if *quiet > 0 {
            let limit = (*quiet).min(allowed).min(ROW);
            let state = (&mut self.t, &mut self.y[..]);
            if let Some((taken, end)) =
                (self.expansion).steps(state, &self.rule, &mut self.lost, &mut self.y_new, limit)
            {
                self.count(run, taken);
                run.out.skip(taken);
                *quiet -= taken;
                match end {
                    RowEnd::Limit => return Ok(None),
                    RowEnd::Next(end) => {
                        let end = end?;
                        self.count(run, 1);
                        return Ok(Some(end));
                    }
                    // Fewer than `limit` ≤ `allowed` were taken: the step may be.
                    RowEnd::Unfactored => {}
                }
            }
        }
        #[cfg(not(feature = "jit"))]
        let _ = (allowed, quiet);
        let end =
            (self.expansion).step(self.t, &self.y, &self.rule, &mut self.lost, &mut self.y_new)?;
        self.count(run, 1);
        if !self.planned {
            self.planned = true;
            self.plan(end.0);
        }
        Ok(Some(end))
    }

    /// After the run's first step, which ended at `t_new`: the steps still to go estimated at
    /// that step's size (the span left over h), and the unrolled expansion compiled now if they
    /// would take the program past `UNROLL_AFTER` expansions (it would be compiled during the
    /// run anyway; now, the steps before that run it too).
    fn plan(&self, t_new: f64) {
        let h = (t_new - self.t).abs();
        let left = (self.rule.t_end - t_new).abs();
        if h > 0.0 && left.is_finite() {
            // A ratio past usize::MAX saturates: a very long run, as it should read.
            self.expansion.plan((left / h).ceil() as usize);
        }
    }
}

impl<S: Dynamics + ?Sized> SegmentStepper<S> for TaylorStepper {
    fn step(&mut self, run: &mut Run<'_, S>) -> Result<Flow> {
        // The steps that nothing watches go in a row, without `Run::accept` (its bookkeeping was
        // a tenth of a small model's step), in compiled code where the expansion is (the Rust
        // around each call was a fifth).
        let mut quiet = run.quiet_steps();
        loop {
            let (t_new, last) = match self.take(run, &mut quiet) {
                Ok(Some(end)) => end,
                Ok(None) => continue,
                Err(e) => {
                    // The failure names the last accepted state, from which this step started.
                    run.out.reached(self.t, &self.y);
                    return Err(e);
                }
            };
            if quiet > 0 && !last {
                quiet -= 1;
                run.out.skip(1);
                std::mem::swap(&mut self.y, &mut self.y_new);
                self.t = t_new;
                continue;
            }
            let t = self.t;
            let step = run.needs_interpolant(t_new).then_some(Interpolant::Taylor {
                t,
                expansion: &self.expansion,
            });
            let flow = run.accept(t, t_new, &self.y_new, last, step.as_ref())?;
            std::mem::swap(&mut self.y, &mut self.y_new);
            self.t = t_new;
            return Ok(flow);
        }
    }
}
