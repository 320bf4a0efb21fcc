//! Ensembles: many runs of [`solve_partial`] at once on a rayon thread pool (feature
//! `parallel`), for sweeps over initial states and parameters.
//!
//! Each run is exactly the [`solve_partial`] of its system and initial state — the same
//! arithmetic in the same order, so the results are bit for bit those of a serial loop, whatever
//! the number of threads — and the results come back in input order. Taylor runs to their final
//! states or states at times are taken several at a time per thread, in the lanes of the
//! machine's vectors (`batch.rs`), with the same steps and bits. A run that fails keeps its
//! [`Failed`] (with what it had computed) and does not stop the others.

use super::batch::{Finished, solve_in_lanes};
use super::{Event, Failed, Method, Options, Solution, solve_partial};
use crate::dynamics::Dynamics;
use crate::error::{Error, Result};
use rayon::prelude::*;

/// The systems of an ensemble's runs.
pub enum Systems<'a, S> {
    /// One system for every run (a sweep over initial states).
    One(&'a S),
    /// Run `i` integrates `build(i)`, built on the thread that runs it (a parameter sweep). A
    /// build that fails fails run `i` only, with that error and nothing computed.
    Each(&'a (dyn Fn(usize) -> Result<S> + Sync)),
    /// Run `i` integrates the system `build(i)` gives, with the events it gives after those of
    /// the options: for events whose conditions depend on the run (a swept threshold, an event
    /// in a swept parameter). A build that fails fails run `i` only.
    EachWithEvents(&'a (dyn Fn(usize) -> Result<(S, Vec<Event>)> + Sync)),
}

// By hand: a derive would ask for `S: Copy`, but only references are copied.
impl<S> Clone for Systems<'_, S> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<S> Copy for Systems<'_, S> {}

/// The outcome of one run: its solution, or its failure with what it had computed.
// `Failed` is a few hundred bytes, once per run: nothing beside the integration.
#[allow(clippy::result_large_err)]
pub type RunResult = std::result::Result<Solution, Failed>;

/// Integrate one run per initial state `(q₀, q̇₀)` of `initial` over `span` with `method` and
/// `options`, on a pool of `workers` threads (0: rayon's default, one per logical core or
/// `RAYON_NUM_THREADS`); the results in the order of `initial`.
///
/// `interrupt` is polled as in [`solve_partial`] by every run, concurrently (hence `Sync`); a
/// run not yet started when it asks to stop fails with [`Error::Interrupted`] at once.
///
/// ```
/// use lagrangian::integrators::{Method, Options, Systems, solve_many, solve_partial};
/// use lagrangian::scenes::SimplePendulum;
/// let pendulum = SimplePendulum::new(1.0, 1.0, 9.81).system();
/// let amplitudes = [0.1, 0.5, 1.0, 2.0];
/// let initial: Vec<_> = amplitudes.iter().map(|a| (vec![*a], vec![0.0])).collect();
/// let states: Vec<_> = initial.iter().map(|(q, qd)| (&q[..], &qd[..])).collect();
/// let options = Options::adaptive(1e-10, 1e-12);
/// let runs = solve_many(Systems::One(&pendulum), &states, (0.0, 5.0), Method::Dop853,
///                       &options, 2, None).unwrap();
/// for ((q0, qd0), run) in states.iter().zip(&runs) {
///     let alone = solve_partial(&pendulum, q0, qd0, (0.0, 5.0), Method::Dop853, &options,
///                               None);
///     assert_eq!(run, &alone); // bit for bit
/// }
/// ```
///
/// # Errors
/// [`Error::InvalidInput`] when the thread pool cannot be built; the failures of the runs are
/// in their results.
#[allow(clippy::result_large_err)]
pub fn solve_many<S: Dynamics + Sync>(
    systems: Systems<'_, S>,
    initial: &[(&[f64], &[f64])],
    span: (f64, f64),
    method: Method,
    options: &Options,
    workers: usize,
    interrupt: Option<&(dyn Fn(f64) -> bool + Sync)>,
) -> Result<Vec<RunResult>> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(workers)
        .build()
        .map_err(|e| Error::InvalidInput {
            what: "workers",
            why: format!("cannot start {workers} threads: {e}"),
        })?;
    // Taylor runs to their final states or states at times go in the lanes of the machine's
    // vectors, several per thread (`batch.rs`); the runs the lanes did not finish run alone.
    let threads = pool.current_num_threads();
    let lanes = pool.install(|| {
        let lanes = |first: &S, each| {
            solve_in_lanes(
                first, each, initial, span, method, options, threads, interrupt,
            )
        };
        match systems {
            Systems::One(system) => lanes(system, None),
            Systems::Each(build) => build(0).ok().and_then(|first| lanes(&first, Some(build))),
            Systems::EachWithEvents(_) => None,
        }
    });
    let run = |(i, finished): (usize, Option<Finished>)| -> RunResult {
        let (q0, qd0) = initial[i];
        if let Some(finished) = finished {
            return Ok(finished.solution(q0.len()));
        }
        let stop = interrupt.map(|f| f as &dyn Fn(f64) -> bool);
        if stop.is_some_and(|f| f(span.0)) {
            return Err(Failed::from(Error::Interrupted { t: span.0 }));
        }
        match &systems {
            Systems::One(system) => solve_partial(*system, q0, qd0, span, method, options, stop),
            Systems::Each(build) => {
                let system = build(i)?;
                solve_partial(&system, q0, qd0, span, method, options, stop)
            }
            Systems::EachWithEvents(build) => {
                let (system, events) = build(i)?;
                let mut own = options.clone();
                own.events.extend(events);
                solve_partial(&system, q0, qd0, span, method, &own, stop)
            }
        }
    };
    // One run per task: runs differ in cost (an amplitude, a parameter), so rayon's work
    // stealing balances them; the indexed collect keeps the input order.
    // A run the lanes finished is only handed over.
    let lanes = lanes.unwrap_or_else(|| vec![None; initial.len()]);
    Ok(pool.install(|| {
        lanes
            .into_par_iter()
            .enumerate()
            .with_max_len(1)
            .map(run)
            .collect()
    }))
}
