//! Constraints stated at run time as expressions (the Python `Model(..., constraints=...,
//! velocity_constraints=...)`): the holonomic rows g(t, q) as one tape with k_h outputs, the
//! velocity rows a(t, q)·q̇ + b(t, q) as one tape with k_v outputs, evaluated over any
//! [`Scalar`] like every other part of an [`EnergyModel`](crate::EnergyModel), so the dual
//! numbers of [`Constrained`](crate::Constrained) give G and γ exactly. At `f64` states G and γ
//! can instead come from a [`ConstraintRows`]: derived once on the expression graph and compiled
//! (`derived::constraint_program`), the constraints' counterpart of eq. 55's program.

use crate::derived::constraint_program::ConstraintRows;
use crate::energies::Constraints;
use crate::error::{Error, Result};
use crate::program::eval::Function;
use crate::scalar::Scalar;

/// [`Constraints`] whose rows are the outputs of compiled expression tapes.
#[derive(Debug, Clone)]
pub struct ExprConstraints {
    dof: usize,
    holonomic: Option<Function>,
    velocity: Option<Function>,
    names: Vec<String>,
    time: bool,
    /// G and γ compiled ([`Constraints::compiled_rows`]), when derived.
    rows: Option<ConstraintRows>,
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
    pub fn with_compiled_rows(self, rows: ConstraintRows) -> Self {
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
        rows.eval(t, q, qd, g, gamma);
        true
    }
}
