//! Forward sensitivities from Python (`simulate(..., sensitivities=[...])`): the directions
//! named by the package, the events' conditions from their serialized expressions, and the
//! crate's run ([`crate::sensitivity::SensitivityProblem`]) handed back as the arrays the
//! package names. The sensitivities themselves — the variational system, the projection onto a
//! constrained model's constraints, the events' times — are the crate's.

use super::events::EventSpec;
use super::model::node_ids;
use crate::error::{Error, Result};
use crate::integrators::Solution;
use crate::sensitivity::{Direction, EventCondition, SensitivitySolution, Variational};

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

impl Sensitivities {
    /// The model's run and the arrays of the crate's run.
    pub(crate) fn of(sol: SensitivitySolution) -> (Solution, Self) {
        let width = 2 * sol.solution.dof;
        let found = Self {
            values: sol.sensitivities,
            columns: sol.directions.len(),
            width,
            events: sol.event_times,
        };
        (sol.solution, found)
    }
}

/// The conditions of the events `specs` for `variational`, differentiated for their times;
/// `reads[e]` lists the model's indices of the parameters event e's spec holds, in the spec's
/// order (an event's expressions are compiled over the parameters it reads only).
///
/// # Errors
/// [`Error::DimensionMismatch`] for `reads` that do not match the specs; [`Error::InvalidInput`]
/// for a condition that is not a node; as [`node_ids`] and [`EventCondition::new`]. (An event
/// that resets the state is refused by the run.)
pub(crate) fn conditions(
    variational: &Variational,
    specs: &[EventSpec],
    reads: &[Vec<usize>],
) -> Result<Vec<EventCondition>> {
    if reads.len() != specs.len() {
        return Err(Error::DimensionMismatch {
            what: "event parameters",
            expected: specs.len(),
            got: reads.len(),
        });
    }
    specs
        .iter()
        .zip(reads)
        .map(|((nodes, condition, _, _, params, _, _, name, _), reads)| {
            if reads.len() != params.len() {
                return Err(Error::DimensionMismatch {
                    what: "event parameters",
                    expected: params.len(),
                    got: reads.len(),
                });
            }
            let (g, ids) = node_ids(nodes)?;
            let root = *ids.get(*condition).ok_or_else(|| Error::InvalidInput {
                what: "event",
                why: format!("event {name:?}: output {condition} is not a node"),
            })?;
            EventCondition::new(&g, root, variational, reads, params)
        })
        .collect()
}
