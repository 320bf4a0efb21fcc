//! The compiled model, [`PyModel`] (`NativeModel` in Python): a system stated in Python by its
//! energies or particles, or a Rust scene, and every method `lagrangian.Model` calls on it:
//! evaluations at given states, `simulate`, the kept-state integrator, equilibria,
//! linearization and modes.
//!
//! `simulate` releases the GIL while it runs and polls for Ctrl-C ([`ctrl_c`]); its energy
//! column is computed on the same thread ([`with_energy`]).

use super::args::{StepOptions, check_finite, check_vector, count, run_options};
use super::error::{self, guard, panic_error};
use super::interrupt::{ctrl_c, interrupted};
use super::model::{self, AnyModel, Backend, CompiledModel, RawNode, Spec, WithLoads};
use super::sensitivity;
use super::solution::Reactions;
use super::states::{self, States};
use super::{events, first_order, integrator, linear, solution};
use crate::constrained::Constrained;
use crate::dynamics::Dynamics;
use crate::error::Error;
use crate::integrators::{Failed, Method, Options, Solution, Status, solve_partial};
use crate::sensitivity::{Direction, SensitivityProblem, Variational};
use crate::statics::{StaticsOptions, constrained_equilibrium, constrained_modes, equilibrium};
use crate::trace::FastPath;
use numpy::ndarray::{Array2, Array3};
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayDyn, PyArrayMethods, PyReadonlyArray1,
    PyReadonlyArray2, PyReadonlyArrayDyn,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple, PyType};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::str::FromStr;
use std::sync::{Arc, Mutex};

/// A compiled model: a system stated in Python by its energies (or particles), or a Rust scene.
///
/// Built by `lagrangian.Model` and `lagrangian.scenes`; immutable and safe to share between
/// threads.
#[pyclass(name = "NativeModel", module = "lagrangian._lagrangian", frozen)]
pub struct PyModel {
    pub(super) model: Arc<AnyModel>,
    pub(super) compiled: Option<Arc<CompiledModel>>,
}

impl PyModel {
    /// The constrained system, or a `ValueError` saying that `what` needs constraints.
    fn constrained(
        &self,
        what: &str,
    ) -> PyResult<&Constrained<AnyModel, crate::routes::ExprConstraints>> {
        self.model.constrained().ok_or_else(|| {
            PyValueError::new_err(format!(
                "{what} needs a constrained model: state constraints=[g(t, q), ...] or \
                 velocity_constraints=[a(t, q)·q̇ + b(t, q), ...] in lg.Model"
            ))
        })
    }

    /// `eval` at each state of (t, q, q̇) in the fast form ([`States`]), each writing a value of
    /// shape `shape` (`[]`: a float); the values as an array of shape `shape`, or (k, *shape)
    /// for k states. `None` when the arguments are not in the fast form. Every evaluation of
    /// `NativeModel` at given states is this with its own `eval`.
    ///
    /// The one exit of every evaluation at given states, so the one place that no NaN or
    /// infinity passes: finite inputs can still overflow (q̇ = 1e200 squared), and then the
    /// result is [`Error::NonFinite`] naming `what`, not the value.
    fn each_state<'py>(
        &self,
        what: &'static str,
        [t, q, qd]: [&Arg<'py>; 3],
        shape: &[usize],
        eval: impl Fn(f64, &[f64], &[f64], &mut [f64]) -> crate::error::Result<()>,
    ) -> Evaluated<'py> {
        guard(|| {
            let n = self.model.dof();
            let Some(states) = States::read(t, q, qd, n) else {
                return Ok(None);
            };
            let size = shape.iter().product::<usize>();
            let mut values = vec![0.0; size * states.count()];
            for (k, out) in values.chunks_exact_mut(size).enumerate() {
                let (q, qd) = states.state(k, n);
                eval(states.t, q, qd, out)?;
                crate::checks::finite(out, what, states.t)?;
            }
            let mut dims = states.rows.map(|k| vec![k]).unwrap_or_default();
            dims.extend_from_slice(shape);
            let py = t.py();
            Ok(Some(match dims.len() {
                0 => values[0].into_pyobject(py)?.into_any(),
                1 => PyArray1::from_vec(py, values).into_any(),
                _ => PyArray1::from_vec(py, values).reshape(dims)?.into_any(),
            }))
        })
    }
}

/// A Python argument of an evaluation at given states (t, q or q̇), in the form it came.
type Arg<'py> = Bound<'py, PyAny>;

/// What an evaluation at given states returns: the values, or `None` when the arguments are not
/// in the fast form (the package converts them and calls again).
type Evaluated<'py> = PyResult<Option<Bound<'py, PyAny>>>;

/// The options of a run as `simulate` receives them.
struct RunSetup<'a> {
    span: (f64, f64),
    method: &'a str,
    steps: StepOptions,
    max_steps: Option<i64>,
    output: (Option<Vec<f64>>, Option<i64>),
    dense: bool,
    backend: &'a str,
}

/// What a run hands back: the model's run and, with sensitivities, theirs; or the failure with
/// what it had computed.
type Outcome = std::result::Result<(Solution, Option<sensitivity::Sensitivities>), Failed>;

impl PyModel {
    /// The method and checked options of `setup`, with the events compiled for a system of
    /// `dof` coordinates, and whether h is a constant of the run.
    fn run_options(
        &self,
        setup: RunSetup<'_>,
        events: Vec<events::EventSpec>,
        dof: usize,
    ) -> PyResult<(Method, Options, bool)> {
        let (t0, t_end) = setup.span;
        check_finite("t0", t0)?;
        check_finite("t_end", t_end)?;
        let backend = Backend::named(setup.backend)?;
        let events = events
            .into_iter()
            .map(|spec| events::event(spec, dof, backend))
            .collect::<Result<Vec<_>, Error>>()?;
        let (method, mut options) = run_options(
            setup.span,
            setup.method,
            setup.steps,
            setup.max_steps,
            setup.output,
        )?;
        let conserved = self.conserved(events.iter().any(|e| e.reset.is_some()));
        options.events = events;
        options.dense = setup.dense;
        options.validate(t0, t_end)?;
        Ok((method, options, conserved))
    }

    /// The variational system of this model along `directions`: compiled once per model
    /// stated in Python, traced from a scene's energies.
    fn variational(&self, directions: &[Direction]) -> Result<Arc<Variational>, Error> {
        match &self.compiled {
            Some(c) => c.variational(directions),
            None => {
                let (graph, parts) = self.model.scene_graph()?;
                let n = self.model.dof();
                Ok(Arc::new(Variational::new(
                    &graph, n, 0, &parts, None, directions,
                )?))
            }
        }
    }

    /// Run `solve` (given the Ctrl-C check) with the GIL released; the solution (the model's
    /// run, and its sensitivities for a run with them) wrapped by `wrap`, with h (and a
    /// constrained model's reactions) from this model and `conserved` saying whether h is a
    /// constant of the run. A failure raises with the partial solution.
    fn run<'py>(
        &self,
        py: Python<'py>,
        conserved: bool,
        solve: impl FnOnce(&dyn Fn(f64) -> bool) -> Outcome + Send,
        wrap: &solution::Wrap<'_, 'py>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let model = &*self.model;
        let n = model.dof();
        // A failure after the run (h cannot be evaluated): the solution as far as it goes (cut
        // where h fails), its last state the one named.
        let failed_at = |sol: Solution, h: Along, error: Error| -> Box<(Failed, Along)> {
            let last = sol.last().map(|(t, q, qd)| (t, q.to_vec(), qd.to_vec()));
            let failed = Failed {
                error,
                partial: Some(Solution {
                    status: Status::Failed,
                    ..sol
                }),
                last,
            };
            Box::new((failed, h))
        };
        type Done = (Solution, Along, Option<sensitivity::Sensitivities>);
        let pending: Mutex<Option<PyErr>> = Mutex::new(None);
        let outcome = py.detach(|| {
            catch_unwind(AssertUnwindSafe(
                || -> Result<Done, Box<(Failed, Along)>> {
                    let interrupt = ctrl_c(&pending);
                    match solve(&interrupt) {
                        Ok((sol, found)) => match with_energy(model, sol) {
                            (sol, h, None) => Ok((sol, h, found)),
                            (sol, h, Some(error)) => Err(failed_at(sol, h, error)),
                        },
                        Err(mut failed) => {
                            let h = match failed.partial.take() {
                                Some(sol) => {
                                    let (sol, h, cut) = with_energy(model, sol);
                                    // The last state kept is the one the error names.
                                    if cut.is_some() {
                                        failed.last = sol
                                            .last()
                                            .map(|(t, q, qd)| (t, q.to_vec(), qd.to_vec()));
                                    }
                                    failed.partial = Some(sol);
                                    h
                                }
                                None => (Vec::new(), None),
                            };
                            if let Some((_, q, qd)) = failed.last.as_mut() {
                                q.truncate(n);
                                qd.truncate(n);
                            }
                            Err(Box::new((failed, h)))
                        }
                    }
                },
            ))
        });
        let (sol, (energy, reactions), sensitivities) = match outcome {
            Err(panic) => return Err(panic_error(panic)),
            Ok(Err(failed)) => {
                let (failed, (energy, reactions)) = *failed;
                if let Error::Interrupted { t } = failed.error {
                    return Err(interrupted(&pending, t));
                }
                return Err(error::with_partial(
                    py, failed, energy, reactions, conserved, wrap,
                ));
            }
            Ok(Ok(done)) => done,
        };
        wrap.wrap(
            solution::RunOutput {
                sol,
                energy,
                conserved,
                reactions,
                sensitivities,
            },
            None,
        )
    }
}

#[pymethods]
impl PyModel {
    /// Compile a model from serialized expression nodes `(op, number, i, j)` and the node
    /// indices of its parts, bound to the parameter values `params`; `backend` says what runs
    /// the derived eq. 55 program (`"native"` or `"interpreter"`).
    #[staticmethod]
    #[pyo3(signature = (nodes, dof, params, kinetic=None, potential=None, dissipation=None,
                        forces=None, positions=None, dim=0, masses=None, backend="native",
                        constraints=None, velocity_constraints=None,
                        constraint_names=Vec::new()))]
    #[allow(clippy::too_many_arguments)]
    fn compile(
        nodes: Vec<RawNode>,
        dof: usize,
        params: Vec<f64>,
        kinetic: Option<usize>,
        potential: Option<usize>,
        dissipation: Option<usize>,
        forces: Option<Vec<usize>>,
        positions: Option<Vec<usize>>,
        dim: usize,
        masses: Option<Vec<usize>>,
        backend: &str,
        constraints: Option<Vec<usize>>,
        velocity_constraints: Option<Vec<usize>>,
        constraint_names: Vec<String>,
    ) -> PyResult<Self> {
        guard(|| {
            let spec = Spec {
                backend: Backend::named(backend)?,
                nodes: &nodes,
                dof,
                params: params.len(),
                kinetic,
                potential,
                dissipation,
                forces,
                positions,
                dim,
                masses,
                constraints,
                velocity_constraints,
                constraint_names,
            };
            let compiled = CompiledModel::new(&spec)?;
            let model = compiled.bind(&params)?;
            Ok(Self {
                model: Arc::new(model),
                compiled: Some(Arc::new(compiled)),
            })
        })
    }

    /// The same compiled model with other parameter values (nothing is recompiled).
    fn with_parameters(&self, params: Vec<f64>) -> PyResult<Self> {
        guard(|| {
            let compiled = self.compiled.as_ref().ok_or_else(|| {
                PyValueError::new_err("a scene is rebuilt from its arguments, not rebound")
            })?;
            Ok(Self {
                model: Arc::new(compiled.bind(&params)?),
                compiled: Some(compiled.clone()),
            })
        })
    }

    /// Number of coordinates.
    #[getter]
    fn dof(&self) -> usize {
        self.model.dof()
    }

    /// Whether h = q̇·p − L is a constant of a run (`stats["conserved"]`, of `simulate` and of
    /// an ensemble): nothing drives or damps the model, and no event `resets` the state.
    fn conserved(&self, resets: bool) -> bool {
        !resets && self.model.structure().conservative()
    }

    /// The structure flags the engine uses: time dependence of L, constant mass matrix,
    /// separability, dissipation, forcing; and whether the equations of motion read t at all
    /// (`driven`: L, Φ or Q″ do), which `time_dependent` alone does not say.
    fn structure<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.model.structure();
        let driven = match &self.compiled {
            Some(compiled) => compiled.driven(),
            None => self.model.scene_driven().unwrap_or(s.time_dependent),
        };
        let d = PyDict::new(py);
        d.set_item("dof", s.dof)?;
        d.set_item("time_dependent", s.time_dependent)?;
        d.set_item("driven", driven)?;
        d.set_item("constant_mass", s.constant_mass)?;
        d.set_item("separable", s.separable)?;
        d.set_item("dissipative", s.dissipative)?;
        d.set_item("forced", s.forced)?;
        d.set_item("conservative", s.conservative())?;
        d.set_item("backend", self.model.backend())?;
        d.set_item("instructions", self.model.instructions())?;
        d.set_item(
            "constraints",
            self.model.constrained().map_or(0, |c| c.rows()),
        )?;
        Ok(d)
    }

    /// Accelerations q̈ at (t, q, q̇) from Lagrange's equations (seed eq. 55): shape (n,), or
    /// (k, n) for k states given as rows. `None` when the arguments are not in the fast form of
    /// [`States`] (the package converts them and calls again).
    fn accelerations<'py>(&self, t: &Arg<'py>, q: &Arg<'py>, qd: &Arg<'py>) -> Evaluated<'py> {
        let (m, n) = (&*self.model, self.model.dof());
        self.each_state("accelerations", [t, q, qd], &[n], |t, q, qd, out| {
            m.accelerations_into(t, q, qd, out)
        })
    }

    /// The names of the constraint rows, holonomic first (empty without constraints).
    #[getter]
    fn constraint_names(&self) -> Vec<String> {
        use crate::energies::Constraints;
        self.model.constrained().map_or_else(Vec::new, |c| {
            (0..c.rows()).map(|i| c.constraints().name(i)).collect()
        })
    }

    /// Number of holonomic rows g(t, q) = 0 (the first of [`constraint_names`]).
    #[getter]
    fn holonomic_count(&self) -> usize {
        use crate::energies::Constraints;
        self.model
            .constrained()
            .map_or(0, |c| c.constraints().holonomic_count())
    }

    /// The Lagrange multipliers λ at (t, q, q̇): shape (k,), or (states, k).
    fn multipliers<'py>(&self, t: &Arg<'py>, q: &Arg<'py>, qd: &Arg<'py>) -> Evaluated<'py> {
        let c = self.constrained("multipliers")?;
        self.each_state("multipliers", [t, q, qd], &[c.rows()], |t, q, qd, out| {
            out.copy_from_slice(c.evaluate(t, q, qd)?.multipliers.as_slice());
            Ok(())
        })
    }

    /// The generalized reaction forces Gᵀλ at (t, q, q̇): shape (n,), or (states, n).
    fn constraint_forces<'py>(&self, t: &Arg<'py>, q: &Arg<'py>, qd: &Arg<'py>) -> Evaluated<'py> {
        let c = self.constrained("constraint_forces")?;
        let n = c.dof();
        self.each_state("constraint forces", [t, q, qd], &[n], |t, q, qd, out| {
            out.copy_from_slice(c.evaluate(t, q, qd)?.reaction_forces.as_slice());
            Ok(())
        })
    }

    /// The Cartesian reaction on each particle at (t, q, q̇), mᵢ (J M⁻¹ Gᵀλ)ᵢ with J = ∂r/∂q
    /// (the reactions' part of each particle's acceleration, times its mass): shape
    /// (count, dim), or (states, count, dim).
    fn particle_reactions<'py>(&self, t: &Arg<'py>, q: &Arg<'py>, qd: &Arg<'py>) -> Evaluated<'py> {
        let c = self.constrained("particle_reactions")?;
        let Some(p) = self.model.tape_particles() else {
            return Err(PyValueError::new_err(
                "particle_reactions needs the particle route (positions= and masses=); a model \
                 stated by its energies has its reactions as constraint_forces (generalized)",
            ));
        };
        let shape = [
            crate::routes::Particles::count(p),
            crate::routes::Particles::dim(p),
        ];
        self.each_state("particle reactions", [t, q, qd], &shape, |t, q, qd, out| {
            particle_reactions(c, p, t, q, qd, out)
        })
    }

    /// The consistent state nearest (q, q̇) at t ([`Constrained::project`]): positions by
    /// Gauss–Newton in the M metric, then velocities by the M-orthogonal projection.
    #[pyo3(signature = (t, q, qd, tol=None))]
    fn project(
        &self,
        t: f64,
        q: Vec<f64>,
        qd: Vec<f64>,
        tol: Option<f64>,
    ) -> PyResult<(Vec<f64>, Vec<f64>)> {
        let c = self.constrained("project")?;
        guard(|| Ok(c.project(t, &q, &qd, tol)?))
    }

    /// Refuse a state off the constraints ([`Constrained::check_consistent_within`]) to the
    /// tolerances a run with `rtol` and `atol` holds (`rtol` `None`: a run of fixed steps;
    /// `atol` `None`: `rtol`), as the run itself would before its first step; nothing without
    /// constraints.
    #[pyo3(signature = (t, q, qd, rtol=None, atol=None))]
    fn check_consistent(
        &self,
        t: f64,
        q: Vec<f64>,
        qd: Vec<f64>,
        rtol: Option<f64>,
        atol: Option<f64>,
    ) -> PyResult<()> {
        let (rtol, atol) =
            crate::integrators::projection_tolerance(rtol.map(|r| (r, atol.unwrap_or(r))));
        match self.model.constrained() {
            Some(c) => guard(|| Ok(c.check_consistent_within(t, &q, &qd, rtol, atol)?)),
            None => Ok(()),
        }
    }

    /// The normalized Taylor coefficients qₖ = q⁽ᵏ⁾(t)/k! and q̇ₖ of the motion through
    /// (t, q, q̇), k = 0..=order, as two arrays of shape (order + 1, n): what the Taylor method
    /// sums at each step (a scene's from its traced expression graph).
    fn taylor_series<'py>(
        &self,
        py: Python<'py>,
        t: f64,
        q: Vec<f64>,
        qd: Vec<f64>,
        order: usize,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let n = self.model.dof();
        let coefficients = guard(|| {
            check_vector("q", &q, n)?;
            check_vector("qd", &qd, n)?;
            check_vector("t", &[t], 1)?;
            let program = self.model.program()?;
            if !(1..=crate::taylor::MAX_TAYLOR_ORDER).contains(&order) {
                return Err(Error::InvalidInput {
                    what: "order",
                    why: format!("{order} is not in 1..={}", crate::taylor::MAX_TAYLOR_ORDER),
                }
                .into());
            }
            let (taylor, params) = program.taylor();
            let mut e = taylor.expansion(params, order);
            e.expand(t, &q, &qd)?;
            let (mut cq, mut cv) = (Vec::new(), Vec::new());
            for k in 0..=order {
                cq.extend_from_slice(e.q(k));
                cv.extend_from_slice(e.qd(k));
            }
            crate::checks::finite(&cq, "Taylor coefficients", t)?;
            crate::checks::finite(&cv, "Taylor coefficients", t)?;
            Ok((cq, cv))
        })?;
        let shape = [order + 1, n];
        Ok((
            PyArray1::from_vec(py, coefficients.0)
                .reshape(shape)?
                .into_any(),
            PyArray1::from_vec(py, coefficients.1)
                .reshape(shape)?
                .into_any(),
        ))
    }

    /// The mass matrix M = ∂²T/∂q̇² at (t, q, q̇): shape (n, n), or (k, n, n).
    fn mass_matrix<'py>(&self, t: &Arg<'py>, q: &Arg<'py>, qd: &Arg<'py>) -> Evaluated<'py> {
        let (m, n) = (&*self.model, self.model.dof());
        self.each_state("mass matrix", [t, q, qd], &[n, n], |t, q, qd, out| {
            out.copy_from_slice(m.mass_matrix(t, q, qd)?.transpose().as_slice());
            Ok(())
        })
    }

    /// The energy function h = q̇·p − L at (t, q, q̇): a float, or shape (k,).
    fn energy<'py>(&self, t: &Arg<'py>, q: &Arg<'py>, qd: &Arg<'py>) -> Evaluated<'py> {
        let m = &*self.model;
        self.each_state("energy", [t, q, qd], &[], |t, q, qd, out| {
            out[0] = m.energy(t, q, qd)?;
            Ok(())
        })
    }

    /// The momenta p = ∂L/∂q̇ at (t, q, q̇): shape (n,), or (k, n).
    fn momenta<'py>(&self, t: &Arg<'py>, q: &Arg<'py>, qd: &Arg<'py>) -> Evaluated<'py> {
        let (m, n) = (&*self.model, self.model.dof());
        self.each_state("momenta", [t, q, qd], &[n], |t, q, qd, out| {
            out.copy_from_slice(m.momenta(t, q, qd)?.as_slice());
            Ok(())
        })
    }

    /// The Lagrangian L = T − U at (t, q, q̇): a float, or shape (k,).
    fn lagrangian<'py>(&self, t: &Arg<'py>, q: &Arg<'py>, qd: &Arg<'py>) -> Evaluated<'py> {
        let m = &*self.model;
        self.each_state("Lagrangian", [t, q, qd], &[], |t, q, qd, out| {
            out[0] = m.lagrangian_at(t, q, qd)?;
            Ok(())
        })
    }

    /// dy/dt = (q̇, q̈) of the first-order system y = (q, q̇) at (t, y): SciPy's `fun(t, y)`;
    /// y of shape (2n,) or (2n, k) (`vectorized=True`).
    fn rhs<'py>(
        &self,
        py: Python<'py>,
        t: f64,
        y: PyReadonlyArrayDyn<'py, f64>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        guard(|| Ok(first_order::rhs(&*self.model, t, y.as_array())?.into_pyarray(py)))
    }

    /// The 2n × 2n Jacobian of `rhs` at (t, y) by forward-mode AD: SciPy's `jac(t, y)`.
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        t: f64,
        y: PyReadonlyArrayDyn<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| Ok(first_order::jacobian(&*self.model, t, y.as_array())?.into_pyarray(py)))
    }

    /// Whether the model has particles to draw (the particle route, or a scene with positions).
    #[getter]
    fn has_positions(&self) -> bool {
        self.model.has_positions()
    }

    /// The particles' positions at the states (t_i, q_i): shape (states, particles, dim), or
    /// `None` for a model stated by its energies only.
    fn positions<'py>(
        &self,
        py: Python<'py>,
        t: PyReadonlyArray1<'py, f64>,
        q: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Option<Bound<'py, PyArray3<f64>>>> {
        guard(|| {
            let n = self.model.dof();
            let t = t.as_array().iter().copied().collect::<Vec<f64>>();
            let q = q.as_array();
            if q.nrows() != t.len() || q.ncols() != n {
                return Err(PyValueError::new_err(format!(
                    "q has shape ({}, {}) but needs ({}, {n}): one row of {n} coordinates per time",
                    q.nrows(),
                    q.ncols(),
                    t.len()
                )));
            }
            let q = q.iter().copied().collect::<Vec<f64>>();
            check_vector("t", &t, t.len())?;
            if let Some(k) = q.iter().position(|x| !x.is_finite()) {
                return Err(PyValueError::new_err(format!(
                    "q[{}, {}] = {} is not finite",
                    k / n,
                    k % n,
                    q[k]
                )));
            }
            let Some((count, dim, r)) = self.model.positions(&t, &q) else {
                return Ok(None);
            };
            if let Some(k) = r.iter().position(|x| !x.is_finite()) {
                let state = k / (count * dim).max(1);
                return Err(Error::NonFinite {
                    what: "positions",
                    t: t[state],
                }
                .into());
            }
            let r = Array3::from_shape_vec((t.len(), count, dim), r)
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
            Ok(Some(r.into_pyarray(py)))
        })
    }

    /// Integrate from (q0, qd0) at t0 to t_end; returns the run as an instance of
    /// `solution_type` (a subclass of [`PySolution`], the package's `Solution`) carrying the
    /// coordinate and event names, or `None` when q0 or qd0 is not in the fast form of
    /// [`states::vector`] (the package converts and checks them and calls again). A failed run
    /// raises with its partial solution, of the same type, as `solution`.
    #[pyo3(signature = (q0, qd0, t_end, t0, method, dt, rtol, atol, t_eval, max_steps, every,
                        events, dense, backend, solution_type, names, event_names))]
    #[allow(clippy::too_many_arguments)]
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        q0: &Bound<'py, PyAny>,
        qd0: &Bound<'py, PyAny>,
        t_end: f64,
        t0: f64,
        method: &str,
        dt: Option<f64>,
        rtol: f64,
        atol: f64,
        t_eval: Option<PyReadonlyArray1<'py, f64>>,
        max_steps: Option<i64>,
        every: Option<i64>,
        events: Vec<events::EventSpec>,
        dense: bool,
        backend: &str,
        solution_type: &Bound<'py, PyType>,
        names: &Bound<'py, PyAny>,
        event_names: &Bound<'py, PyAny>,
    ) -> PyResult<Option<Bound<'py, PyAny>>> {
        let n = self.model.dof();
        let (Some(q0), Some(qd0)) = (states::vector(q0, n), states::vector(qd0, n)) else {
            return Ok(None);
        };
        let setup = RunSetup {
            span: (t0, t_end),
            method,
            steps: StepOptions { dt, rtol, atol },
            max_steps,
            output: (
                t_eval.map(|t| t.as_array().iter().copied().collect()),
                every,
            ),
            dense,
            backend,
        };
        let (method, options, conserved) = self.run_options(setup, events, n)?;
        let wrap = solution::Wrap {
            kind: solution_type,
            names,
            event_names,
        };
        let system = &*self.model;
        #[allow(clippy::result_large_err)]
        let solve = |interrupt: &dyn Fn(f64) -> bool| {
            let span = (t0, t_end);
            if !system.is_scene() {
                return solve_partial(system, &q0, &qd0, span, method, &options, Some(interrupt))
                    .map(|sol| (sol, None));
            }
            let run = scene_run(system);
            solve_partial(&run, &q0, &qd0, span, method, &options, Some(interrupt))
                .map(|sol| (sol, None))
        };
        self.run(py, conserved, solve, &wrap).map(Some)
    }

    /// `simulate` with the sensitivities along `directions` (`("param", index)`, `("q0", i)`,
    /// `("qd0", i)`): the variational system runs in the model's place, and the solution
    /// carries `sensitivities` (outputs × directions × 2n) and `event_sensitivities` (per event,
    /// occurrences × directions), which the package names. `params` are the model's parameter
    /// values (a scene has none on its graph); `error_all` controls the sensitivities' error
    /// too (else only (q, q̇)'s); `event_reads` the model's indices of each event's parameters.
    #[pyo3(signature = (q0, qd0, t_end, t0, method, dt, rtol, atol, t_eval, max_steps, every,
                        events, dense, backend, solution_type, names, event_names, directions,
                        params, error_all, event_reads))]
    #[allow(clippy::too_many_arguments)]
    fn simulate_sensitivities<'py>(
        &self,
        py: Python<'py>,
        q0: Vec<f64>,
        qd0: Vec<f64>,
        t_end: f64,
        t0: f64,
        method: &str,
        dt: Option<f64>,
        rtol: f64,
        atol: f64,
        t_eval: Option<PyReadonlyArray1<'py, f64>>,
        max_steps: Option<i64>,
        every: Option<i64>,
        events: Vec<events::EventSpec>,
        dense: bool,
        backend: &str,
        solution_type: &Bound<'py, PyType>,
        names: &Bound<'py, PyAny>,
        event_names: &Bound<'py, PyAny>,
        directions: Vec<(String, usize)>,
        params: Vec<f64>,
        error_all: bool,
        event_reads: Vec<Vec<usize>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let n = self.model.dof();
        check_vector("q0", &q0, n)?;
        check_vector("qd0", &qd0, n)?;
        let directions = sensitivity::directions(&directions)?;
        let variational = self.variational(&directions)?;
        let conditions = sensitivity::conditions(&variational, &events, &event_reads)?;
        let setup = RunSetup {
            span: (t0, t_end),
            method,
            steps: StepOptions { dt, rtol, atol },
            max_steps,
            output: (
                t_eval.map(|t| t.as_array().iter().copied().collect()),
                every,
            ),
            dense,
            backend,
        };
        let size = n * (1 + directions.len());
        let (method, mut options, conserved) = self.run_options(setup, events, size)?;
        if !error_all {
            options.error_coordinates = Some(n);
        }
        let params = if self.compiled.is_some() {
            &params[..]
        } else {
            &[]
        };
        let problem = SensitivityProblem::new(&*self.model, &variational, params)?
            .with_event_conditions(conditions);
        let wrap = solution::Wrap {
            kind: solution_type,
            names,
            event_names,
        };
        #[allow(clippy::result_large_err)]
        let solve = |interrupt: &dyn Fn(f64) -> bool| {
            problem
                .solve_partial(&q0, &qd0, (t0, t_end), method, &options, Some(interrupt))
                .map(|sol| {
                    let (sol, found) = sensitivity::Sensitivities::of(sol);
                    (sol, Some(found))
                })
        };
        self.run(py, conserved, solve, &wrap)
    }

    /// The variational system along `directions` (as `simulate_sensitivities` names them) as
    /// a model of its own, n(1 + m) coordinates, bound to `params` (a scene: none): what an
    /// ensemble with sensitivities runs, binding it per run to swept parameters.
    fn variational_model(
        &self,
        directions: Vec<(String, usize)>,
        params: Vec<f64>,
    ) -> PyResult<Self> {
        guard(|| {
            if self.model.constrained().is_some() {
                return Err(Error::InvalidInput {
                    what: "sensitivities",
                    why: "an ensemble of a constrained model does not carry sensitivities (each \
                          run's initial sensitivities are projected onto its constraints): run \
                          simulate(..., sensitivities=...) per run"
                        .into(),
                }
                .into());
            }
            let directions = sensitivity::directions(&directions)?;
            let variational = self.variational(&directions)?;
            let count = if self.compiled.is_some() {
                params.len()
            } else {
                0
            };
            let compiled = CompiledModel::of_variational(&variational, count);
            let model = compiled.bind(&params[..count])?;
            Ok(Self {
                model: Arc::new(model),
                compiled: Some(Arc::new(compiled)),
            })
        })
    }

    /// An integrator standing at (t0, q0, q̇0) with this method and these options (`dt` a step
    /// size > 0: each call's span gives the direction); see [`integrator::PyIntegrator`].
    #[pyo3(signature = (q0, qd0, t0, method, dt, rtol, atol, max_steps, events, backend))]
    #[allow(clippy::too_many_arguments)]
    fn integrator(
        &self,
        q0: &Bound<'_, PyAny>,
        qd0: &Bound<'_, PyAny>,
        t0: f64,
        method: &str,
        dt: Option<f64>,
        rtol: f64,
        atol: f64,
        max_steps: Option<i64>,
        events: Vec<events::EventSpec>,
        backend: &str,
    ) -> PyResult<integrator::PyIntegrator> {
        let n = self.model.dof();
        let q0 = integrator::state_vector("q0", q0, n)?;
        let qd0 = integrator::state_vector("qd0", qd0, n)?;
        guard(|| {
            let backend = Backend::named(backend)?;
            let events = events
                .into_iter()
                .map(|spec| events::event(spec, n, backend))
                .collect::<Result<Vec<_>, Error>>()?;
            let method = Method::from_str(method)?;
            // A step size, as the Rust API states it: each call's span gives the direction.
            let mut options = match dt {
                Some(dt) => Options::fixed(dt),
                None => Options::adaptive(rtol, atol),
            };
            if let Some(max_steps) = max_steps {
                options.max_steps = count("max_steps", max_steps)?;
            }
            let conserved = self.conserved(events.iter().any(|e| e.reset.is_some()));
            options.events = events;
            // Refused here, as a run refuses it.
            if let Some(c) = self.model.constrained() {
                let (rtol, atol) = options.projection_tolerance();
                c.check_consistent_within(t0, &q0, &qd0, rtol, atol)?;
            }
            integrator::PyIntegrator::new(
                self.model.clone(),
                (t0, q0, qd0),
                method,
                options,
                conserved,
            )
        })
    }

    /// An equilibrium near `q_guess` (q̈ = 0 at q̇ = 0; virtual work, seed §3, when T is
    /// quadratic in q̇), loads added; `frozen` solves at t even if the forces change with t.
    /// Returns (q, residual, iterations, stability, eigenvalues, stiffness, reason,
    /// spectrum re, spectrum im) — the spectrum `None` where M is singular.
    #[pyo3(signature = (q_guess, t=0.0, loads=None, params=Vec::new(), max_iterations=100,
                        max_step=f64::INFINITY, frozen=false))]
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn equilibrium<'py>(
        &self,
        py: Python<'py>,
        q_guess: Vec<f64>,
        t: f64,
        loads: Option<(Vec<RawNode>, Vec<usize>)>,
        params: Vec<f64>,
        max_iterations: usize,
        max_step: f64,
        frozen: bool,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let n = self.model.dof();
        check_vector("q_guess", &q_guess, n)?;
        check_finite("t", t)?;
        let options = StaticsOptions {
            max_iterations,
            max_step,
            frozen_time: frozen,
            ..StaticsOptions::default()
        };
        let loads = guard(|| {
            Ok(loads
                .map(|(nodes, outputs)| model::loads(&nodes, &outputs, n, &params))
                .transpose()?)
        })?;
        if let Some(c) = self.model.constrained() {
            let found = py
                .detach(|| {
                    catch_unwind(AssertUnwindSafe(|| match &loads {
                        Some(loads) => {
                            let with = WithLoads {
                                model: c.system(),
                                loads,
                            };
                            let system = Constrained::new(with, c.constraints());
                            constrained_equilibrium(&system, t, &q_guess, &options)
                        }
                        None => constrained_equilibrium(c, t, &q_guess, &options),
                    }))
                })
                .map_err(panic_error)??;
            let k = &found.stiffness;
            let stiffness = Array2::from_shape_fn((n, n), |(i, j)| k[(i, j)]);
            return (
                PyArray1::from_slice(py, found.q.as_slice()),
                found.residual,
                found.iterations,
                linear::stability_name(found.stability),
                PyArray1::from_slice(py, found.eigenvalues.as_slice()),
                stiffness.into_pyarray(py),
                found.reason.clone(),
                None::<Bound<'py, PyAny>>,
                None::<Bound<'py, PyAny>>,
                PyArray1::from_slice(py, found.multipliers.as_slice()),
                PyArray1::from_slice(py, found.reaction_forces.as_slice()),
            )
                .into_pyobject(py);
        }
        let model = self.model.clone();
        let found = py
            .detach(|| {
                catch_unwind(AssertUnwindSafe(|| match &loads {
                    Some(loads) => {
                        let with = WithLoads {
                            model: &model,
                            loads,
                        };
                        equilibrium(&with, t, &q_guess, &options)
                    }
                    None => equilibrium(&*model, t, &q_guess, &options),
                }))
            })
            .map_err(panic_error)??;
        let k = &found.stiffness;
        let stiffness = Array2::from_shape_fn((n, n), |(i, j)| k[(i, j)]);
        let (re, im) = match &found.spectrum {
            Some(s) => {
                let (re, im) = linear::complex_vector(py, s);
                (Some(re), Some(im))
            }
            None => (None, None),
        };
        (
            PyArray1::from_slice(py, found.q.as_slice()),
            found.residual,
            found.iterations,
            linear::stability_name(found.stability),
            PyArray1::from_slice(py, found.eigenvalues.as_slice()),
            stiffness.into_pyarray(py),
            found.reason.clone(),
            re,
            im,
            None::<Bound<'py, PyAny>>,
            None::<Bound<'py, PyAny>>,
        )
            .into_pyobject(py)
    }

    /// The linearization at (t, q, q̇) (`crate::linearize`) as a pair: (t, q, qd,
    /// accelerations, M, C, K, A, eigenvalues re, eigenvalues im), and B = ∂ẋ/∂u for the
    /// parameters of indices `inputs` at the values `params` (`None` without `inputs`).
    #[pyo3(signature = (t, q, qd, inputs=None, params=Vec::new()))]
    fn linearize<'py>(
        &self,
        py: Python<'py>,
        t: f64,
        q: Vec<f64>,
        qd: Vec<f64>,
        inputs: Option<Vec<usize>>,
        params: Vec<f64>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| {
            let inputs = inputs.as_deref().map(|i| (i, params.as_slice()));
            let compiled = self.compiled.as_deref();
            linear::linearize_py(py, &*self.model, compiled, (t, &q, &qd), inputs)
        })
    }

    /// The modes about the equilibrium q at t (`crate::modes`), as a tuple (see `linear.rs`).
    ///
    /// A constrained model's n − k modes on its holonomic manifold
    /// ([`crate::constrained_modes`]), with λ from [`crate::constrained_equilibrium`] started
    /// at q (which must already be an equilibrium there).
    fn modes<'py>(&self, py: Python<'py>, t: f64, q: Vec<f64>) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| match self.model.constrained() {
            Some(c) => {
                let options = StaticsOptions {
                    frozen_time: true,
                    ..StaticsOptions::default()
                };
                let at = constrained_equilibrium(c, t, &q, &options)?;
                let found = constrained_modes(c, t, &q, at.multipliers.as_slice())?;
                linear::modes_tuple(py, &found)
            }
            None => linear::modes_py(py, &*self.model, t, &q),
        })
    }
}

/// What is computed along a run after it: the energy function h at every point and, for a
/// constrained model, the multipliers and reactions there.
type Along = (Vec<f64>, Option<Reactions>);

/// The energy function h (and for a constrained model λ and Gᵀλ, from
/// [`Constrained::evaluate`]) at every point of `sol`. Where they cannot be evaluated (h
/// overflows, G loses rank), the solution is cut before that point and the error says where:
/// no NaN in what is returned.
fn with_energy(model: &AnyModel, mut sol: Solution) -> (Solution, Along, Option<Error>) {
    let constrained = model.constrained();
    let mut h = Vec::with_capacity(sol.len());
    let mut reactions = constrained.map(|c| Reactions {
        multipliers: Vec::with_capacity(sol.len() * c.rows()),
        rows: c.rows(),
        forces: Vec::with_capacity(sol.len() * sol.dof),
    });
    for i in 0..sol.len() {
        let (t, q, qd) = (sol.t[i], sol.q_at(i), sol.qd_at(i));
        let outcome = model.energy(t, q, qd).and_then(|e| {
            if !e.is_finite() {
                return Err(Error::NonFinite { what: "energy", t });
            }
            let at = match constrained {
                Some(c) => Some(c.evaluate(t, q, qd)?),
                None => None,
            };
            Ok((e, at))
        });
        match outcome {
            Ok((e, at)) => {
                h.push(e);
                if let (Some(r), Some(at)) = (reactions.as_mut(), at) {
                    r.multipliers.extend_from_slice(at.multipliers.as_slice());
                    r.forces.extend_from_slice(at.reaction_forces.as_slice());
                }
            }
            Err(error) => {
                sol.t.truncate(i);
                sol.q.truncate(i * sol.dof);
                sol.qd.truncate(i * sol.dof);
                return (sol, (h, reactions), Some(error));
            }
        }
    }
    (sol, (h, reactions), None)
}

/// The Cartesian reaction on each particle at (t, q, q̇): mᵢ (J M⁻¹ Gᵀλ)ᵢ, J = ∂r/∂q by dual
/// numbers, into `out` (count × dim).
fn particle_reactions(
    c: &Constrained<AnyModel, crate::routes::ExprConstraints>,
    p: &crate::routes::TapeParticles,
    t: f64,
    q: &[f64],
    qd: &[f64],
    out: &mut [f64],
) -> crate::error::Result<()> {
    use num_dual::Dual64;
    let reaction = c.evaluate(t, q, qd)?.reaction_forces;
    // M⁻¹ Gᵀλ: the reactions' part of q̈.
    let m = c.system().mass_matrix(t, q, qd)?;
    let dq = m
        .cholesky()
        .map(|f| f.solve(&reaction))
        .ok_or_else(|| Error::SingularMassMatrix {
            t,
            q: q.to_vec(),
            reason: "not positive definite",
        })?;
    // J (M⁻¹ Gᵀλ) in one directional pass.
    let qq: Vec<Dual64> = q
        .iter()
        .zip(dq.iter())
        .map(|(&x, &v)| Dual64::new(x, v))
        .collect();
    let mut r = vec![Dual64::from(0.0); out.len()];
    crate::routes::Particles::positions(p, Dual64::from(t), &qq, &mut r);
    let dim = crate::routes::Particles::dim(p);
    for (k, (o, x)) in out.iter_mut().zip(&r).enumerate() {
        *o = p.masses()[k / dim] * x.eps;
    }
    Ok(())
}

/// A scene's run on [`FastPath`]: the Rust route, then the traced program once the run has spent
/// a fair part of what compiling it costs. `LAGRANGIAN_SCENE_PATH=rust` (or `compiled`) holds
/// every run on one route, for benchmarks against the other.
pub(super) fn scene_run<P: std::ops::Deref<Target = AnyModel>>(model: P) -> FastPath<P> {
    match std::env::var("LAGRANGIAN_SCENE_PATH").as_deref() {
        Ok("rust") => FastPath::switching_at(model, AnyModel::program, usize::MAX),
        Ok("compiled") => FastPath::switching_at(model, AnyModel::program, 0),
        _ => FastPath::new(model, AnyModel::program),
    }
}
