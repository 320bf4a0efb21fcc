//! A run with sensitivities of a model: the variational system bound to the parameter values,
//! run in the model's place — held to a constrained model's constraints as the model's own run
//! is ([`super::projected`]) — and split into the model's run, its sensitivities and the
//! sensitivities of its events' times.

use super::events::EventCondition;
use super::projected::Projected;
use super::{SensitivitySolution, Variational};
use crate::dynamics::Dynamics;
use crate::error::{Error, Result};
use crate::integrators::{Failed, Method, Options, Solution, Status, solve_partial};
use crate::program::eval::Function;
use crate::routes::EnergyModel;

/// What a run with sensitivities is made of besides its span, method and options: the model,
/// its variational system along the directions wanted, the parameter values, and the
/// conditions of the events whose times are differentiated.
///
/// ```
/// use lagrangian::sensitivity::{Direction, EventCondition, SensitivityProblem, Variational};
/// use lagrangian::integrators::{Event, Method, Options, Output};
/// use lagrangian::tape::{Binary, Energies, EnergyModel, EomProgram, Function, Graph, Inputs,
///                        Tape};
/// # use approx::assert_relative_eq;
/// // A ball thrown up at v₀ under gravity g: T = ½ ẏ², U = g y. It lands (y = 0) at
/// // t* = 2 v₀/g, so dt*/dg = −2 v₀/g² and dt*/dv₀ = 2/g.
/// let mut graph = Graph::new();
/// let (g, y, v, half) = (graph.param(0), graph.coord(0), graph.velocity(0), graph.constant(0.5));
/// let v2 = graph.binary(Binary::Mul, v, v)?;
/// let kinetic = graph.binary(Binary::Mul, half, v2)?;
/// let potential = graph.binary(Binary::Mul, g, y)?;
/// let parts = Energies { kinetic, potential: Some(potential), ..Energies::default() };
/// let params = [9.81];
/// let inputs = Inputs::kinetic(1, 1);
/// let model = EnergyModel::new(
///     1,
///     Function::new(std::sync::Arc::new(Tape::new(&graph, &[kinetic], inputs, "T")?), &params)?,
///     Some(Function::new(std::sync::Arc::new(Tape::new(&graph, &[potential], inputs, "U")?),
///                        &params)?),
///     None,
///     None,
/// )?;
/// let wrt = [Direction::Parameter(0), Direction::Velocity(0)];
/// let variational = Variational::new(&graph, 1, 1, &parts, None, &wrt)?;
/// // The event's condition y, as a node of the model's graph, which reads the parameter g.
/// let landing = EventCondition::new(&graph, y, &variational, &[0], &params)?;
/// let options = Options::adaptive(1e-12, 1e-12)
///     .with_output(Output::Final)
///     .with_event(Event::new("landing", |_t, q, _qd| q[0]).falling().terminal(1));
/// let v0 = 3.0;
/// let sol = SensitivityProblem::new(&model, &variational, &params)?
///     .with_event_conditions(vec![landing])
///     .solve(&[0.0], &[v0], (0.0, 10.0), Method::Dop853, &options)?;
/// let dt = &sol.event_times[0]; // occurrence 0: dt*/dg, dt*/dv₀
/// assert_relative_eq!(dt[0], -2.0 * v0 / (9.81 * 9.81), epsilon = 1e-12);
/// assert_relative_eq!(dt[1], 2.0 / 9.81, epsilon = 1e-12);
/// # Ok::<(), lagrangian::Error>(())
/// ```
pub struct SensitivityProblem<'a, S: ?Sized> {
    /// `None` for [`solve_sensitivities`]: no constraints, no event times.
    model: Option<&'a S>,
    variational: &'a Variational,
    params: &'a [f64],
    conditions: Vec<EventCondition>,
}

impl<'a, S: Dynamics + ?Sized> SensitivityProblem<'a, S> {
    /// The run of `model` with the sensitivities along `variational`'s directions, the
    /// variational system bound to `params` (the model's parameter values). `model` is the
    /// model the variational system was derived from: its constraints hold the run (the state
    /// projected as the model's own run projects it, the sensitivities with it) and its q̈ gives
    /// the rate of an event's condition.
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] when the model's coordinates are not the variational
    /// system's n; [`Error::InvalidInput`] when the model has constraints and the variational
    /// system was derived without them, or the other way round.
    pub fn new(model: &'a S, variational: &'a Variational, params: &'a [f64]) -> Result<Self> {
        if model.dof() != variational.dof() {
            return Err(Error::DimensionMismatch {
                what: "model coordinates",
                expected: variational.dof(),
                got: model.dof(),
            });
        }
        if model.constraints().is_some() != variational.tangent.is_some() {
            return Err(Error::InvalidInput {
                what: "sensitivities",
                why: "the model and its variational system disagree about constraints: derive \
                      the variational system with the model's constraints (ConstraintNodes), \
                      and run it with the constrained model"
                    .into(),
            });
        }
        Ok(Self {
            model: Some(model),
            variational,
            params,
            conditions: Vec::new(),
        })
    }

    /// The run of a model without constraints, known by its variational system alone (no
    /// event times: [`solve_sensitivities`]).
    fn without_model(variational: &'a Variational, params: &'a [f64]) -> Self {
        Self {
            model: None,
            variational,
            params,
            conditions: Vec::new(),
        }
    }

    /// The conditions of the run's events, one per event of the options in their order, for
    /// the sensitivities of the events' times ([`SensitivitySolution::event_times`]). Without
    /// them the events are found and their variational states kept, but their times are not
    /// differentiated.
    pub fn with_event_conditions(mut self, conditions: Vec<EventCondition>) -> Self {
        self.conditions = conditions;
        self
    }

    /// Run from the model's (q₀, q̇₀) over `span` with `method` and `options`.
    ///
    /// # Errors
    /// As [`solve_partial`](Self::solve_partial), without the partial run.
    pub fn solve(
        &self,
        q0: &[f64],
        qd0: &[f64],
        span: (f64, f64),
        method: Method,
        options: &Options,
    ) -> Result<SensitivitySolution> {
        self.solve_partial(q0, qd0, span, method, options, None)
            .map_err(|failed| failed.error)
    }

    /// [`solve`](Self::solve) with an interrupt check (as
    /// [`solve_partial`](crate::integrators::solve_partial)), keeping what a failed run
    /// computed: the model's run as far as it went (n coordinates), and its last state.
    ///
    /// A constrained model's run is held to the constraints by the methods that project each
    /// step (the Runge–Kutta methods, radau5 and `auto`): the state as the plain run projects
    /// it, the sensitivities onto the tangent space at the projected state. The other methods
    /// run the index-1 equations unprojected; the statistics' `constraint_residual` is then
    /// the worst residual of the model's constraints over the run's outputs.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for an event with a reset, or a number of event conditions that
    /// is neither zero nor the events'; as [`ConstraintAccess::check_state`] for a constrained
    /// model's initial state, [`Variational::bind`], [`Variational::initial_state`] and
    /// [`solve_partial`](crate::integrators::solve_partial); [`Error::NonFinite`] when an
    /// event's condition crosses zero at rate 0 (its time has no derivative), with the run.
    ///
    /// [`ConstraintAccess::check_state`]: crate::dynamics::ConstraintAccess::check_state
    #[allow(clippy::result_large_err)]
    pub fn solve_partial(
        &self,
        q0: &[f64],
        qd0: &[f64],
        span: (f64, f64),
        method: Method,
        options: &Options,
        interrupt: Option<&dyn Fn(f64) -> bool>,
    ) -> std::result::Result<SensitivitySolution, Failed> {
        let early = |error: Error| Failed {
            error,
            partial: None,
            last: None,
        };
        let v = self.variational;
        let (n, m) = (v.dof(), v.directions().len());
        check_no_resets(options).map_err(early)?;
        if !self.conditions.is_empty() && self.conditions.len() != options.events.len() {
            return Err(early(Error::InvalidInput {
                what: "sensitivities",
                why: format!(
                    "{} event conditions for {} events: give one per event, in the options' \
                     order, or none",
                    self.conditions.len(),
                    options.events.len()
                ),
            }));
        }
        let constraints = self.model.and_then(|model| model.constraints());
        if let Some(c) = constraints {
            c.check_state(span.0, q0, qd0, options.projection_tolerance())
                .map_err(early)?;
        }
        let system = v.bind(self.params).map_err(early)?;
        let (q, qd) = v
            .initial_state(span.0, q0, qd0, self.params)
            .map_err(early)?;
        let projects = matches!(
            method,
            Method::Auto | Method::Rk4 | Method::Dopri5 | Method::Dop853 | Method::Radau5
        );
        let run = match (constraints, &v.tangent) {
            (Some(state), Some(tangent)) if projects => {
                let bound = Function::new(tangent.tape.clone(), self.params).map_err(early)?;
                let projected = Projected {
                    system: &system,
                    state,
                    tangent,
                    bound,
                    n,
                };
                solve_partial(&projected, &q, &qd, span, method, options, interrupt)
            }
            _ => solve_partial(&system, &q, &qd, span, method, options, interrupt),
        };
        let unprojected = constraints.filter(|_| !projects);
        // The worst residual of the model's constraints over an unprojected run's outputs.
        let residual = |sol: &mut Solution| -> Result<()> {
            if let Some(c) = unprojected {
                for i in 0..sol.len() {
                    let r = c.worst_residual(sol.t[i], sol.q_at(i), sol.qd_at(i))?;
                    let stats = &mut sol.stats;
                    stats.constraint_residual = stats.constraint_residual.max(r);
                }
            }
            Ok(())
        };
        let failed = |error: Error, mut sol: Solution| {
            sol.status = Status::Failed;
            let last = sol.last().map(|(t, q, qd)| (t, q.to_vec(), qd.to_vec()));
            Failed {
                error,
                partial: Some(sol),
                last,
            }
        };
        match run {
            Ok(sol) => {
                let mut split = v.split(sol);
                if let Err(error) = residual(&mut split.solution) {
                    return Err(failed(error, split.solution));
                }
                if let Some(model) = self.model.filter(|_| !self.conditions.is_empty()) {
                    let times = split
                        .event_states
                        .iter()
                        .zip(&self.conditions)
                        .map(|(occurrences, c)| c.times(occurrences, model, n, m))
                        .collect::<Result<Vec<_>>>();
                    match times {
                        Ok(times) => split.event_times = times,
                        Err(error) => return Err(failed(error, split.solution)),
                    }
                }
                Ok(split)
            }
            Err(mut failure) => {
                match failure.partial.take() {
                    Some(sol) => {
                        let mut sol = v.split(sol).solution;
                        // The residual is a diagnostic: the run's own error is the one raised.
                        let _ = residual(&mut sol);
                        failure.last = sol.last().map(|(t, q, qd)| (t, q.to_vec(), qd.to_vec()));
                        failure.partial = Some(sol);
                    }
                    None => {
                        if let Some((_, q, qd)) = failure.last.as_mut() {
                            q.truncate(n);
                            qd.truncate(n);
                        }
                    }
                }
                Err(failure)
            }
        }
    }
}

/// Run the variational system of `variational` — of a model without constraints — at the
/// parameter values `params` from the model's (q₀, q̇₀) over `span` with `method` and
/// `options`, and split the result ([`Variational::split`]). A constrained model's run, or one
/// with the sensitivities of its events' times, is a [`SensitivityProblem`].
///
/// Events that reset the state are refused: a reset moves the sensitivities too (by the
/// reset's own derivatives), which the variational system does not state.
///
/// # Errors
/// As [`Variational::bind`], [`Variational::initial_state`] and
/// [`solve_partial`](crate::integrators::solve_partial); [`Error::InvalidInput`] for an event
/// with a reset, or for the variational system of a constrained model (whose run needs the
/// model's constraints: [`SensitivityProblem`]).
pub fn solve_sensitivities(
    variational: &Variational,
    params: &[f64],
    q0: &[f64],
    qd0: &[f64],
    span: (f64, f64),
    method: Method,
    options: &Options,
) -> Result<SensitivitySolution> {
    if variational.tangent.is_some() {
        return Err(Error::InvalidInput {
            what: "sensitivities",
            why: "the variational system is a constrained model's, whose run is held to the \
                  model's constraints: run it with SensitivityProblem::new(&model, \
                  &variational, params)"
                .into(),
        });
    }
    SensitivityProblem::<EnergyModel>::without_model(variational, params)
        .solve(q0, qd0, span, method, options)
}

/// [`Error::InvalidInput`] when an event of `options` resets the state (see
/// [`solve_sensitivities`]).
pub fn check_no_resets(options: &Options) -> Result<()> {
    match options.events.iter().find(|e| e.reset.is_some()) {
        Some(e) => Err(Error::InvalidInput {
            what: "sensitivities",
            why: format!(
                "event {:?} resets the state, and a reset would move the sensitivities by its \
                 own derivatives, which are not derived: run without the reset, or without \
                 sensitivities",
                e.name
            ),
        }),
        None => Ok(()),
    }
}
