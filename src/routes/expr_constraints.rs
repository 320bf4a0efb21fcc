//! Constraints stated at run time as expressions (the Python `Model(..., constraints=...,
//! velocity_constraints=...)`): the holonomic rows g(t, q) as one tape with k_h outputs, the
//! velocity rows a(t, q)·q̇ + b(t, q) as one tape with k_v outputs, evaluated over any
//! [`Scalar`] like every other part of an [`EnergyModel`](crate::EnergyModel), so the dual
//! numbers of [`Constrained`](crate::Constrained) give G and γ exactly. At `f64` states G and γ
//! can instead come from [`CompiledRows`]: derived once on the expression graph and compiled
//! (machine code with the `jit` feature), the constraints' counterpart of eq. 55's program.

use crate::Scalar;
use crate::energies::Constraints;
use crate::error::{Error, Result};
use crate::expr::derive::{Seeds, Wrt, gradient, tangents};
use crate::expr::graph::Graph;
use crate::program::compile::Tape;
use crate::program::eval::Function;
use crate::program::inputs::Inputs;
use crate::scalar::with_buf;
use std::sync::Arc;

/// G and γ of a set of rows derived on the expression graph, as one tape over (t, q, q̇) whose
/// outputs are G row after row (holonomic rows ∂g/∂q, velocity rows ∂(a·q̇ + b)/∂q̇), then γ
/// (holonomic rows: the second derivative of g along (t + s, q + s q̇), two tangent sweeps;
/// velocity rows: the first derivative of a·q̇ + b along it, q̇ held), with its machine code where
/// Cranelift compiled it. Not yet bound to parameter values.
#[derive(Debug, Clone)]
pub struct CompiledRows {
    tape: Arc<Tape>,
    #[cfg(feature = "jit")]
    native: Option<Arc<crate::native::tape::NativeTape>>,
}

impl CompiledRows {
    /// Derive G and γ of the rows `holonomic` and `velocity` (nodes of `graph`, which gains the
    /// derivatives' nodes) of a model of `dof` coordinates and `params` parameters; `native`
    /// compiles the tape to machine code where the platform has it.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for a row that is not a node of the graph; what compiling the
    /// tape refuses.
    pub fn derive(
        graph: &mut Graph,
        dof: usize,
        params: usize,
        holonomic: &[usize],
        velocity: &[usize],
        native: bool,
    ) -> Result<Self> {
        let zero = graph.constant(0.0);
        let one = graph.constant(1.0);
        // Along the motion with q̈ = 0: t ↦ 1, qⱼ ↦ q̇ⱼ, q̇ held.
        let mut along = Seeds::new().time(one);
        for j in 0..dof {
            let v = graph.velocity(j);
            along = along.coord(j, v);
        }
        let mut outputs = Vec::with_capacity((holonomic.len() + velocity.len()) * (dof + 1));
        for (rows, wrt) in [(holonomic, Wrt::Position), (velocity, Wrt::Velocity)] {
            for &row in rows {
                let grad = gradient(graph, row, wrt, dof)?;
                outputs.extend(grad.into_iter().map(|d| d.unwrap_or(zero)));
            }
        }
        let first: Vec<usize> = tangents(graph, holonomic, &along)?
            .into_iter()
            .map(|d| d.unwrap_or(zero))
            .collect();
        let second = tangents(graph, &first, &along)?;
        let moving = tangents(graph, velocity, &along)?;
        outputs.extend(second.into_iter().chain(moving).map(|d| d.unwrap_or(zero)));
        let tape = Tape::new(
            graph,
            &outputs,
            Inputs::kinetic(dof, params),
            "constraints' G and γ",
        )?;
        #[cfg(not(feature = "jit"))]
        let _ = native;
        Ok(Self {
            // Any failure of Cranelift leaves the interpreter.
            #[cfg(feature = "jit")]
            native: native
                .then(|| crate::native::tape::NativeTape::compile(&tape).ok())
                .flatten()
                .map(Arc::new),
            tape: Arc::new(tape),
        })
    }

    /// Bound to parameter values.
    ///
    /// # Errors
    /// As [`Function::new`].
    pub fn bind(&self, params: &[f64]) -> Result<BoundRows> {
        Ok(BoundRows {
            function: Function::new(self.tape.clone(), params)?,
            #[cfg(feature = "jit")]
            native: self.native.clone(),
        })
    }
}

/// [`CompiledRows`] bound to parameter values.
#[derive(Debug, Clone)]
pub struct BoundRows {
    function: Function,
    #[cfg(feature = "jit")]
    native: Option<Arc<crate::native::tape::NativeTape>>,
}

impl BoundRows {
    /// G (row-major) then γ at (t, q, q̇) into `out`.
    fn eval(&self, t: f64, q: &[f64], qd: &[f64], out: &mut [f64]) {
        #[cfg(feature = "jit")]
        if let Some(native) = &self.native {
            return native.eval(&self.function.consts, t, q, qd, out);
        }
        self.function.eval_into(t, q, qd, out)
    }

    /// The same rows with other parameter values.
    fn with_parameters(&self, params: &[f64]) -> Result<Self> {
        Ok(Self {
            function: self.function.with_parameters(params)?,
            #[cfg(feature = "jit")]
            native: self.native.clone(),
        })
    }
}

/// [`Constraints`] whose rows are the outputs of compiled expression tapes.
#[derive(Debug, Clone)]
pub struct ExprConstraints {
    dof: usize,
    holonomic: Option<Function>,
    velocity: Option<Function>,
    names: Vec<String>,
    time: bool,
    /// G and γ compiled ([`Constraints::compiled_rows`]), when derived.
    rows: Option<BoundRows>,
}

impl ExprConstraints {
    /// The rows of `holonomic` (over t and q; it may not read q̇) and of `velocity` (over t, q
    /// and q̇, linear in q̇) for a model of `dof` coordinates, named by `names` (holonomic rows
    /// first; empty for the default names "constraint i").
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the holonomic tape reads q̇, a tape has the wrong number of
    /// coordinates, there is no row at all, or the names do not match the rows.
    pub fn new(
        dof: usize,
        holonomic: Option<Function>,
        velocity: Option<Function>,
        names: Vec<String>,
    ) -> Result<Self> {
        let bad = |why: String| Error::InvalidInput {
            what: "constraints",
            why,
        };
        if holonomic
            .as_ref()
            .is_some_and(|h| h.tape().depends_on_velocity())
        {
            return Err(bad(
                "a holonomic constraint g(t, q) = 0 may not read the velocities: state it as a \
                 velocity constraint instead"
                    .into(),
            ));
        }
        for f in holonomic.iter().chain(&velocity) {
            if f.tape().inputs().dof != dof {
                return Err(bad(format!(
                    "a constraint tape of {} coordinates for a model of {dof}",
                    f.tape().inputs().dof
                )));
            }
        }
        let rows = holonomic.as_ref().map_or(0, |f| f.tape().outputs())
            + velocity.as_ref().map_or(0, |f| f.tape().outputs());
        if rows == 0 {
            return Err(bad("no constraint rows".into()));
        }
        if !names.is_empty() && names.len() != rows {
            return Err(bad(format!(
                "{} names for {rows} constraint rows",
                names.len()
            )));
        }
        let time = holonomic
            .iter()
            .chain(&velocity)
            .any(|f| f.tape().depends_on_time());
        Ok(Self {
            dof,
            holonomic,
            velocity,
            names,
            time,
            rows: None,
        })
    }

    /// The same rows with G and γ from `rows` at `f64` states (which must be derived from
    /// these rows, bound to the same parameter values).
    pub fn with_compiled_rows(self, rows: BoundRows) -> Self {
        Self {
            rows: Some(rows),
            ..self
        }
    }

    /// The same rows with the tapes bound to other parameter values.
    ///
    /// # Errors
    /// As [`Function::new`].
    pub fn with_parameters(&self, params: &[f64]) -> Result<Self> {
        let rebind =
            |f: &Option<Function>| f.as_ref().map(|f| f.with_parameters(params)).transpose();
        Ok(Self {
            holonomic: rebind(&self.holonomic)?,
            velocity: rebind(&self.velocity)?,
            rows: self
                .rows
                .as_ref()
                .map(|r| r.with_parameters(params))
                .transpose()?,
            ..self.clone()
        })
    }

    /// Number of coordinates the rows are stated over.
    pub fn dof(&self) -> usize {
        self.dof
    }
}

impl Constraints for ExprConstraints {
    fn holonomic_count(&self) -> usize {
        self.holonomic.as_ref().map_or(0, |f| f.tape().outputs())
    }

    #[inline]
    fn holonomic<D: Scalar>(&self, t: D, q: &[D], out: &mut [D]) {
        if let Some(f) = &self.holonomic {
            f.eval_into(t, q, &[], out);
        }
    }

    fn velocity_count(&self) -> usize {
        self.velocity.as_ref().map_or(0, |f| f.tape().outputs())
    }

    #[inline]
    fn velocity<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        if let Some(f) = &self.velocity {
            f.eval_into(t, q, qd, out);
        }
    }

    fn depends_on_time(&self) -> bool {
        self.time
    }

    fn name(&self, row: usize) -> String {
        self.names
            .get(row)
            .cloned()
            .unwrap_or_else(|| format!("constraint {row}"))
    }

    fn compiled_rows(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        g: &mut [f64],
        gamma: &mut [f64],
    ) -> bool {
        let Some(rows) = &self.rows else {
            return false;
        };
        let kn = g.len();
        with_buf::<f64, 64, _>(kn + gamma.len(), 0.0, |out| {
            rows.eval(t, q, qd, out);
            g.copy_from_slice(&out[..kn]);
            gamma.copy_from_slice(&out[kn..]);
        });
        true
    }
}
