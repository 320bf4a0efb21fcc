//! The sensitivities of the events' times. An event's time t* moves with θ because the root of
//! its condition g(t, q, q̇; p) = 0 does: by the implicit function theorem,
//!
//! ```text
//! dt*/dθⱼ = −(∂g/∂q sⱼ + ∂g/∂q̇ ṡⱼ + ∂g/∂pⱼ) / ġ,   ġ = ∂g/∂t + ∂g/∂q q̇ + ∂g/∂q̇ q̈
//! ```
//!
//! at the root. The partial derivatives are derived on the condition's own graph (one tangent
//! sweep per input) and compiled once ([`EventCondition`]); sⱼ and ṡⱼ are the variational
//! state at the occurrence, q̈ the model's.

use super::Variational;
use crate::derived::variational::Direction;
use crate::dynamics::Dynamics;
use crate::error::{Error, Result};
use crate::expr::derive::{Seeds, tangents};
use crate::expr::graph::Graph;
use crate::integrators::Occurrences;
use crate::program::{compile::Tape, eval::Function, inputs::Inputs};
use std::sync::Arc;

/// An event's condition g(t, q, q̇; p), differentiated for the sensitivity of its time along
/// each direction of a variational system: ∂g/∂t, ∂g/∂q, ∂g/∂q̇ and ∂g/∂pⱼ per direction
/// (zero for an initial state), compiled and bound to the condition's parameter values. Give
/// one per event of the run's options ([`SensitivityProblem::with_event_conditions`]); the
/// event itself (its [`Event`](crate::integrators::Event)) still finds the roots.
///
/// [`SensitivityProblem::with_event_conditions`]: super::SensitivityProblem::with_event_conditions
#[derive(Debug, Clone)]
pub struct EventCondition {
    derivatives: Function,
}

impl EventCondition {
    /// The condition `root`, a node of `graph` over the model's t, q and q̇ (n =
    /// [`Variational::dof`] coordinates) and the graph's own parameters, for the directions of
    /// `variational`. `reads[i]` is the model's index of the graph's parameter i, and
    /// `params[i]` its value; a condition stated on the model's own graph reads every
    /// parameter, `reads = [0, 1, …]`.
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] when `reads` and `params` differ in length;
    /// [`Error::InvalidInput`] when `root` is not a node of the graph; as [`tangents`] and
    /// [`Tape::new`].
    pub fn new(
        graph: &Graph,
        root: usize,
        variational: &Variational,
        reads: &[usize],
        params: &[f64],
    ) -> Result<Self> {
        if reads.len() != params.len() {
            return Err(Error::DimensionMismatch {
                what: "event parameters",
                expected: params.len(),
                got: reads.len(),
            });
        }
        if root >= graph.len() {
            return Err(Error::InvalidInput {
                what: "event",
                why: format!("node {root} is not a node of the condition's graph"),
            });
        }
        let n = variational.dof();
        let mut g = graph.clone();
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
            // The model's parameter p is the graph's parameter `at`, if the condition reads it.
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
        Ok(Self {
            derivatives: Function::new(Arc::new(tape), params)?,
        })
    }

    /// dt*/dθⱼ at each occurrence of the event (m numbers each, in the directions' order) from
    /// the variational state there; `model` gives q̈ at the roots.
    ///
    /// # Errors
    /// [`Error::NonFinite`] when the condition crosses zero at rate 0 (ġ = 0: a grazing root,
    /// whose time has no derivative); as [`Dynamics::accelerations`].
    pub(super) fn times<S: Dynamics + ?Sized>(
        &self,
        occurrences: &Occurrences,
        model: &S,
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
            self.derivatives.eval_into(t, &q[..n], &qd[..n], &mut d);
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
                        what: "sensitivity of an event's time (the condition crosses zero at \
                               rate 0)",
                        t,
                    });
                }
                out.push(dt);
            }
        }
        Ok(out)
    }
}
