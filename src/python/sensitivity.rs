//! Forward sensitivities from Python (`simulate(..., sensitivities=[...])`): the directions
//! named by the package, the variational system run in their place
//! ([`crate::sensitivity::Variational`]), and what comes out of it — the model's run, the
//! sensitivities at each output and the sensitivities of the events' times.
//!
//! An event's time t* moves with θ because the root of its condition g(t, q, q̇; p) = 0 does:
//! by the implicit function theorem, dt*/dθⱼ = −(∂g/∂q sⱼ + ∂g/∂q̇ ṡⱼ + ∂g/∂pⱼ) / ġ, with
//! ġ = ∂g/∂t + ∂g/∂q q̇ + ∂g/∂q̇ q̈ at the root. The partial derivatives are derived on the
//! condition's own graph (one tangent sweep per input) and compiled once per run.

use super::events::EventSpec;
use super::model::{AnyModel, node_ids};
use crate::derived::variational::Direction;
use crate::dynamics::Dynamics;
use crate::error::{Error, Result};
use crate::expr::derive::{Seeds, tangents};
use crate::integrators::Occurrences;
use crate::integrators::Solution;
use crate::program::{compile::Tape, eval::Function, inputs::Inputs};
use crate::sensitivity::Variational;
use std::sync::Arc;

/// The directions the package names: `("param", index)`, `("q0", i)` or `("qd0", i)`.
///
/// # Errors
/// [`Error::InvalidInput`] for another kind.
pub(crate) fn directions(named: &[(String, usize)]) -> Result<Vec<Direction>> {
    named
        .iter()
        .map(|(kind, i)| match kind.as_str() {
            "param" => Ok(Direction::Parameter(*i)),
            "q0" => Ok(Direction::Position(*i)),
            "qd0" => Ok(Direction::Velocity(*i)),
            other => Err(Error::InvalidInput {
                what: "sensitivities",
                why: format!("unknown direction {other:?}: \"param\", \"q0\" or \"qd0\""),
            }),
        })
        .collect()
}

/// The sensitivities of a run, as the solution hands them to Python.
#[derive(Debug)]
pub(crate) struct Sensitivities {
    /// ∂(q, q̇)/∂θⱼ: `columns` blocks of `width` = 2n numbers per output.
    pub(crate) values: Vec<f64>,
    pub(crate) columns: usize,
    pub(crate) width: usize,
    /// Per event, dt*/dθⱼ: `columns` numbers per occurrence.
    pub(crate) events: Vec<Vec<f64>>,
}

/// A run of the variational system: the system, and the derivatives of each event's condition
/// (∂g/∂t, ∂g/∂q, ∂g/∂q̇, then ∂g/∂pⱼ per direction, zero for an initial state).
pub(crate) struct SensitivityRun {
    pub(crate) variational: Arc<Variational>,
    conditions: Vec<Function>,
}

impl SensitivityRun {
    /// For `variational` and the events `specs` of a model of `n` coordinates; `reads[e]`
    /// lists the model's indices of the parameters event e's spec holds, in the spec's order
    /// (an event's expressions are compiled over the parameters it reads only).
    ///
    /// # Errors
    /// As [`node_ids`], [`tangents`] and [`Tape::new`]; [`Error::InvalidInput`] for an event
    /// that resets the state (see [`crate::sensitivity::check_no_resets`]) or `reads` that do
    /// not match the specs.
    pub(crate) fn new(
        variational: Arc<Variational>,
        specs: &[EventSpec],
        reads: &[Vec<usize>],
    ) -> Result<Self> {
        let n = variational.dof();
        let mut conditions = Vec::with_capacity(specs.len());
        if reads.len() != specs.len() {
            return Err(Error::DimensionMismatch {
                what: "event parameters",
                expected: specs.len(),
                got: reads.len(),
            });
        }
        for ((nodes, condition, targets, _, params, _, _, name, _), reads) in
            specs.iter().zip(reads)
        {
            if reads.len() != params.len() {
                return Err(Error::DimensionMismatch {
                    what: "event parameters",
                    expected: params.len(),
                    got: reads.len(),
                });
            }
            if !targets.is_empty() {
                return Err(Error::InvalidInput {
                    what: "sensitivities",
                    why: format!(
                        "event {name:?} resets the state, and a reset would move the \
                         sensitivities by its own derivatives, which are not derived: run \
                         without the reset, or without sensitivities"
                    ),
                });
            }
            let (mut g, ids) = node_ids(nodes)?;
            let root = *ids.get(*condition).ok_or_else(|| Error::InvalidInput {
                what: "event",
                why: format!("event {name:?}: output {condition} is not a node"),
            })?;
            let one = g.constant(1.0);
            let zero = g.constant(0.0);
            let mut seeds = vec![Seeds::new().time(one)];
            seeds.extend((0..n).map(|i| Seeds::new().coord(i, one)));
            seeds.extend((0..n).map(|i| Seeds::new().velocity(i, one)));
            let mut outputs = Vec::with_capacity(seeds.len() + variational.directions().len());
            for s in &seeds {
                outputs.push(tangents(&mut g, &[root], s)?[0].unwrap_or(zero));
            }
            for d in variational.directions() {
                // The model's parameter p is the spec's parameter `at`, if the event reads it.
                let at = match *d {
                    Direction::Parameter(p) => reads.iter().position(|&i| i == p),
                    Direction::Position(_) | Direction::Velocity(_) => None,
                };
                outputs.push(match at {
                    Some(at) => {
                        let s = Seeds::new().param(at, one);
                        tangents(&mut g, &[root], &s)?[0].unwrap_or(zero)
                    }
                    None => zero,
                });
            }
            let tape = Tape::new(
                &g,
                &outputs,
                Inputs::kinetic(n, params.len()),
                "derivatives of an event condition",
            )?;
            conditions.push(Function::new(Arc::new(tape), params)?);
        }
        Ok(Self {
            variational,
            conditions,
        })
    }

    /// The model's run and its sensitivities from the variational system's run `sol`; `model`
    /// gives q̈ at the events' roots.
    ///
    /// # Errors
    /// [`Error::NonFinite`] when an event's condition does not cross zero at a finite rate
    /// (ġ = 0: a grazing root, whose time has no derivative); the model's run comes with it.
    pub(crate) fn finish(
        &self,
        model: &AnyModel,
        sol: Solution,
    ) -> (Solution, Result<Sensitivities>) {
        let split = self.variational.split(sol);
        let (n, m) = (self.variational.dof(), self.variational.directions().len());
        let events = split
            .event_states
            .iter()
            .zip(&self.conditions)
            .map(|(occurrences, condition)| event_times(occurrences, condition, model, n, m))
            .collect::<Result<Vec<_>>>();
        let found = events.map(|events| Sensitivities {
            values: split.sensitivities,
            columns: m,
            width: 2 * n,
            events,
        });
        (split.solution, found)
    }
}

/// dt*/dθⱼ at each occurrence (m numbers each) from the variational state there.
fn event_times(
    occurrences: &Occurrences,
    condition: &Function,
    model: &AnyModel,
    n: usize,
    m: usize,
) -> Result<Vec<f64>> {
    let size = n * (1 + m);
    let mut d = vec![0.0; 1 + 2 * n + m];
    let mut out = Vec::with_capacity(occurrences.t.len() * m);
    for (k, &t) in occurrences.t.iter().enumerate() {
        let (q, qd) = (
            &occurrences.q[k * size..(k + 1) * size],
            &occurrences.qd[k * size..(k + 1) * size],
        );
        condition.eval_into(t, &q[..n], &qd[..n], &mut d);
        let accelerations = model.accelerations(t, &q[..n], &qd[..n])?;
        let (gq, rest) = d[1..].split_at(n);
        let (gv, gp) = rest.split_at(n);
        let rate = d[0]
            + (0..n)
                .map(|i| gq[i] * qd[i] + gv[i] * accelerations[i])
                .sum::<f64>();
        for j in 0..m {
            let at = n + j * n;
            let moved = gp[j]
                + (0..n)
                    .map(|i| gq[i] * q[at + i] + gv[i] * qd[at + i])
                    .sum::<f64>();
            let dt = -moved / rate;
            if !dt.is_finite() {
                return Err(Error::NonFinite {
                    what: "sensitivity of an event's time (the condition crosses zero at rate 0)",
                    t,
                });
            }
            out.push(dt);
        }
    }
    Ok(out)
}
