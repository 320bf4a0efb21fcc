//! An ensemble's Taylor runs in lanes (feature `parallel`): each thread of the pool advances
//! [`LANES`] runs at once, one per lane of the machine's vectors, each lane with its own state,
//! parameters and step size ([`BatchExpansion`]). A run that reaches its end leaves its lane to
//! the next run waiting; one whose step fails, or that would pass `max_steps`, leaves it to be
//! run alone, from its start, by [`solve_partial`](super::solve_partial), which fails it with
//! the error it would have alone (the lanes take a run's steps bit for bit as it takes them
//! alone, so that run reaches the same failure). The finished runs are what
//! `solve_partial` gives: the same states, bits and counters.
//!
//! Taken by `solve_many` for `Method::Taylor` keeping the final state (`Output::Final`) or
//! states at given times (`Output::Times`, from each step's polynomial as a run alone evaluates
//! it), with no events and no dense output, on a model without constraints whose Taylor program
//! every run shares (one model, or one compiled model bound to each run's parameters), of at
//! least half as many runs as there are lanes; other ensembles run one run per task.

use super::taylor::order_for;
use super::{Method, Options, Output, Solution, Statistics, Status};
use crate::checks::check_state;
use crate::derived::eom_program::EomFunction;
use crate::dynamics::Dynamics;
use crate::error::Result;
use crate::taylor::StepRule;
use crate::taylor::TaylorProgram;
use crate::taylor::batch::{BatchExpansion, LANES, LaneStates, LaneStep};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

/// A run the lanes took to its end: the states it kept (its final one, or those at the times
/// asked for), and its steps.
#[derive(Debug, Clone, Default)]
pub(super) struct Finished {
    t: Vec<f64>,
    q: Vec<f64>,
    qd: Vec<f64>,
    steps: usize,
    order: usize,
}

impl Finished {
    /// Keep the state y = (q, q̇) at t.
    fn keep(&mut self, t: f64, y: &[f64]) {
        let n = y.len() / 2;
        self.t.push(t);
        self.q.extend_from_slice(&y[..n]);
        self.qd.extend_from_slice(&y[n..]);
    }

    /// The solution `solve_partial` gives this run.
    pub(super) fn solution(self, dof: usize) -> Solution {
        let mut stats = Statistics::new(Method::Taylor, None);
        stats.accepted_steps = self.steps;
        stats.rhs_evaluations = self.steps * self.order;
        Solution {
            dof,
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

/// Batch steps between two polls of the interrupt check.
const POLL_EVERY: usize = 64;

/// The runs of an ensemble taken in lanes, when it can be ([`self`]'s conditions): per run,
/// `Some` when the lanes finished it, `None` when it is to run alone. `None` when the ensemble
/// is not one the lanes take. Every run integrates `first`, or with `each`, the system
/// `each(i)` builds (`first` is `each(0)`: it gives the program and the checks the runs share).
#[allow(clippy::too_many_arguments)]
pub(super) fn solve_in_lanes<S: Dynamics + Sync>(
    first: &S,
    each: Option<&(dyn Fn(usize) -> Result<S> + Sync)>,
    initial: &[(&[f64], &[f64])],
    span: (f64, f64),
    method: Method,
    options: &Options,
    threads: usize,
    interrupt: Option<&(dyn Fn(f64) -> bool + Sync)>,
) -> Option<Vec<Option<Finished>>> {
    let (t0, t_end) = span;
    let times: &[f64] = match &options.output {
        Output::Final => &[],
        Output::Times(times) => times,
        Output::Steps | Output::Every(_) => return None,
    };
    let plain = method == Method::Taylor
        && options.events.is_empty()
        && !options.dense
        && options.dt.is_none()
        && t_end.is_finite()
        && t_end != t0
        // Fewer runs than half the lanes go faster alone.
        && initial.len() >= LANES / 2;
    if !plain {
        return None;
    }
    let system = first;
    let n = system.dof();
    let (q0, qd0) = initial[0];
    let fits = system.constraints().is_none()
        && options.validate(t0, t_end).is_ok()
        && options.check_method(method).is_ok()
        && options.check_error_coordinates(n).is_ok()
        && check_state(n, t0, q0, Some(qd0)).is_ok()
        && method.check_fits(system, t0, q0, qd0).is_ok();
    if !fits {
        return None;
    }
    let (program, params) = EomFunction::of(system.taylor_program().ok()?).taylor();
    let (program, params) = (program.clone(), params.to_vec());
    let order = order_for(options.rtol.min(options.atol));
    if !BatchExpansion::fits(&program, order) {
        return None;
    }
    let span_length = (t_end - t0).abs();
    let rule = StepRule {
        rtol: options.rtol,
        atol: options.atol,
        h_max: options.max_step.unwrap_or(span_length).min(span_length),
        min_step: options.min_step,
        t_end,
        dir: if t_end > t0 { 1.0 } else { -1.0 },
        controlled: options
            .error_coordinates
            .map_or(f64::INFINITY, |k| k as f64),
    };
    let lanes = Lanes {
        times,
        keep_final: options.output == Output::Final,
        each,
        initial,
        t0,
        rule,
        order,
        max_steps: options.max_steps,
        program,
        params,
        next: AtomicUsize::new(0),
        interrupt,
    };
    let mut results: Vec<Option<Finished>> = vec![None; initial.len()];
    let finished: Vec<Vec<(usize, Finished)>> = {
        use rayon::prelude::*;
        // A thread per LANES runs, at most `threads`.
        (0..threads.clamp(1, initial.len().div_ceil(LANES)))
            .into_par_iter()
            .map(|_| lanes.work())
            .collect()
    };
    for (i, run) in finished.into_iter().flatten() {
        results[i] = Some(run);
    }
    Some(results)
}

/// What the threads share: the runs, their rule, and the next run waiting.
struct Lanes<'a, S> {
    /// The times to keep the states at (`Output::Times`), in the run's direction.
    times: &'a [f64],
    /// Whether to keep the final state (`Output::Final`).
    keep_final: bool,
    /// Each run's system, where runs differ (else every run's parameters are `params`).
    each: Option<&'a (dyn Fn(usize) -> Result<S> + Sync)>,
    initial: &'a [(&'a [f64], &'a [f64])],
    t0: f64,
    rule: StepRule,
    order: usize,
    max_steps: usize,
    program: Arc<TaylorProgram>,
    /// The parameters of the one system.
    params: Vec<f64>,
    next: AtomicUsize,
    interrupt: Option<&'a (dyn Fn(f64) -> bool + Sync)>,
}

/// A lane's run: its index, the next of the times to keep and what it kept so far.
#[derive(Debug, Clone)]
struct InLane {
    run: usize,
    next: usize,
    kept: Finished,
}

impl<S: Dynamics + Sync> Lanes<'_, S> {
    /// One thread's share: runs taken from the queue into lanes until none is left; the runs
    /// it finished.
    fn work(&self) -> Vec<(usize, Finished)> {
        let n = self.program.dof();
        let mut expansion = BatchExpansion::new(self.program.clone(), self.order);
        let mut states = LaneStates::new(n);
        let mut lanes: [Option<InLane>; LANES] = std::array::from_fn(|_| None);
        if self.each.is_none() {
            for lane in 0..LANES {
                expansion.bind(lane, &self.params);
            }
        }
        let mut finished = Vec::new();
        let mut y = vec![0.0; 2 * n];
        let mut stopped = false;
        for round in 0.. {
            for (lane, slot) in lanes.iter_mut().enumerate() {
                if slot.is_none() && !stopped {
                    *slot = self.load(lane, &mut expansion, &mut states, &mut y);
                }
            }
            if lanes.iter().all(Option::is_none) {
                break;
            }
            // A run that would pass `max_steps` runs alone, to fail with `TooManySteps`.
            for slot in &mut lanes {
                if slot
                    .as_ref()
                    .is_some_and(|r| r.kept.steps >= self.max_steps)
                {
                    *slot = None;
                }
            }
            if round % POLL_EVERY == 0
                && let Some(stop) = self.interrupt
                && let Some(lane) = lanes.iter().position(Option::is_some)
                && stop(states.t.0[lane])
            {
                // The runs in the lanes and those waiting run alone: each fails at once.
                stopped = true;
                lanes = std::array::from_fn(|_| None);
                continue;
            }
            let t = states.t;
            let outcome = expansion.step(&mut states, &self.rule);
            for (lane, slot) in lanes.iter_mut().enumerate() {
                let Some(run) = slot else { continue };
                if outcome[lane] == LaneStep::Failed {
                    *slot = None;
                    continue;
                }
                run.kept.steps += 1;
                self.keep_times(run, &expansion, &states, lane, t.0[lane]);
                if outcome[lane] == LaneStep::Last {
                    if self.keep_final {
                        run.kept.keep(states.t.0[lane], &states.state(lane));
                    }
                    if let Some(run) = slot.take() {
                        finished.push((run.run, run.kept));
                    }
                }
            }
        }
        finished
    }

    /// Keep `run`'s states at the times asked for up to the end of its step from t in `lane`,
    /// from the step's polynomial (`Recorder::dense`: the new state itself at the step's end).
    fn keep_times(
        &self,
        run: &mut InLane,
        expansion: &BatchExpansion,
        states: &LaneStates,
        lane: usize,
        t: f64,
    ) {
        let (dir, t_new) = (self.rule.dir, states.t.0[lane]);
        let due = |next: usize| {
            self.times
                .get(next)
                .filter(|&&ti| (ti - t_new) * dir <= 0.0)
        };
        if due(run.next).is_none() {
            return;
        }
        let mut y = states.state(lane);
        while let Some(&ti) = due(run.next) {
            run.next += 1;
            if ti == t_new {
                y = states.state(lane);
            } else {
                expansion.eval(lane, ti - t, &mut y);
            }
            run.kept.keep(ti, &y);
        }
    }

    /// The next waiting run the lanes can take, put in `lane` (bound to its parameters); runs
    /// they cannot take are skipped (left to run alone). `None` when none is left.
    fn load(
        &self,
        lane: usize,
        expansion: &mut BatchExpansion,
        states: &mut LaneStates,
        y: &mut [f64],
    ) -> Option<InLane> {
        let n = self.program.dof();
        loop {
            let run = self.next.fetch_add(1, Ordering::Relaxed);
            let (q0, qd0) = *self.initial.get(run)?;
            if check_state(n, self.t0, q0, Some(qd0)).is_err() {
                continue;
            }
            if let Some(build) = self.each {
                let Ok(system) = build(run) else { continue };
                let Ok(eom) = system.taylor_program() else {
                    continue;
                };
                let (program, params) = EomFunction::of(eom).taylor();
                if !Arc::ptr_eq(program, &self.program) {
                    continue;
                }
                expansion.bind(lane, params);
            }
            y[..n].copy_from_slice(q0);
            y[n..].copy_from_slice(qd0);
            states.load(lane, self.t0, y, &self.rule);
            // The times at or before t₀ keep the initial state (`Recorder::start`).
            let dir = self.rule.dir;
            let mut kept = Finished {
                order: self.order,
                ..Finished::default()
            };
            let next = (self.times.iter())
                .take_while(|&&ti| (ti - self.t0) * dir <= 0.0)
                .count();
            for _ in 0..next {
                kept.keep(self.t0, y);
            }
            return Some(InLane { run, next, kept });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::derived::eom_program::EomProgram;
    use crate::derived::models;
    use crate::expr::graph::Graph;
    use crate::program::compile::Tape;
    use crate::program::eval::Function;
    use crate::program::inputs::Inputs;
    use crate::routes::EnergyModel;

    /// The lanes take every run of a plain Taylor ensemble to the end, for one model and for
    /// one program bound per run, to the final state or states at times, and leave to run alone the run they cannot start (a NaN)
    /// and every run of an ensemble they do not take (one keeping every step, one of too few
    /// runs).
    #[test]
    fn the_lanes_take_what_they_can() {
        let mut g = Graph::new();
        let parts = models::double_pendulum(&mut g).unwrap();
        let program = EomProgram::new(&mut g, 2, 5, &parts).unwrap();
        let tape = |node: usize, inputs| Arc::new(Tape::new(&g, &[node], inputs, "part").unwrap());
        let (t, u) = (
            tape(parts.kinetic, Inputs::kinetic(2, 5)),
            tape(parts.potential.unwrap(), Inputs::potential(2, 5)),
        );
        let bind = |p: &[f64]| -> crate::error::Result<EnergyModel> {
            EnergyModel::new(
                2,
                Function::new(t.clone(), p)?,
                Some(Function::new(u.clone(), p)?),
                None,
                None,
            )?
            .with_program(program.bind(p)?)
        };
        let model = bind(&[1.0, 1.0, 1.0, 1.0, 9.81]).unwrap();
        let each = |i: usize| bind(&[1.0, 1.0, 1.0, 1.0, 9.0 + i as f64]);
        let states: Vec<[f64; 2]> = (0..11)
            .map(|i| [0.1 * i as f64, -0.05 * i as f64])
            .collect();
        let mut initial: Vec<(&[f64], &[f64])> =
            states.iter().map(|q| (&q[..], &states[0][..])).collect();
        let nan = [f64::NAN, 0.0];
        initial[3].0 = &nan;
        let options = Options::adaptive(1e-9, 1e-9).with_output(Output::Final);
        type Each<'a> = Option<&'a (dyn Fn(usize) -> crate::error::Result<EnergyModel> + Sync)>;
        let taken_of = |initial: &[(&[f64], &[f64])], each: Each<'_>, options: &Options| {
            let first = each.map_or_else(|| model.clone(), |build| build(0).unwrap());
            solve_in_lanes(
                &first,
                each,
                initial,
                (0.0, 2.0),
                Method::Taylor,
                options,
                2,
                None,
            )
            .map(|runs| runs.iter().map(Option::is_some).collect::<Vec<_>>())
        };
        let taken = |each: Each<'_>, options: &Options| taken_of(&initial, each, options);
        let mut want = vec![true; initial.len()];
        want[3] = false;
        assert_eq!(taken(None, &options), Some(want.clone()));
        assert_eq!(taken(Some(&each), &options), Some(want.clone()));
        let timed = options
            .clone()
            .with_output(Output::Times(vec![0.0, 0.5, 2.0]));
        assert_eq!(taken(None, &timed), Some(want));
        let steps = options.clone().with_output(Output::Steps);
        assert_eq!(taken(None, &steps), None);
        // Too few runs to fill half the lanes.
        let few = &initial[..LANES / 2 - 1];
        assert_eq!(taken_of(few, None, &options), None);
    }
}
