//! Constraints stated at run time as expressions (the Python `Model(..., constraints=...,
//! velocity_constraints=...)`): the holonomic rows g(t, q) as one tape with k_h outputs, the
//! velocity rows a(t, q)·q̇ + b(t, q) as one tape with k_v outputs, evaluated over any
//! [`Scalar`] like every other part of an [`EnergyModel`](crate::EnergyModel), so the dual
//! numbers of [`Constrained`](crate::Constrained) give G and γ exactly.

use crate::Scalar;
use crate::energies::Constraints;
use crate::error::{Error, Result};
use crate::program::eval::Function;

/// [`Constraints`] whose rows are the outputs of compiled expression tapes.
#[derive(Debug, Clone, PartialEq)]
pub struct ExprConstraints {
    dof: usize,
    holonomic: Option<Function>,
    velocity: Option<Function>,
    names: Vec<String>,
    time: bool,
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
        })
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::graph::{Binary, Graph};
    use crate::program::{compile::Tape, inputs::Inputs};
    use crate::{Constrained, KineticEnergy, System};
    use std::sync::Arc;

    /// A unit point mass in the plane.
    struct Point;
    impl KineticEnergy for Point {
        fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
            (qd[0] * qd[0] + qd[1] * qd[1]) * 0.5
        }
    }

    /// x² + y² − l² (l a parameter) and the velocity row x ẏ − y ẋ − t (reads t).
    fn rows(l: f64) -> ExprConstraints {
        let mut g = Graph::new();
        let (x, y, l_) = (g.coord(0), g.coord(1), g.param(0));
        let (xd, yd, t) = (g.velocity(0), g.velocity(1), g.time());
        let x2 = g.powi(x, 2).unwrap();
        let y2 = g.powi(y, 2).unwrap();
        let l2 = g.powi(l_, 2).unwrap();
        let r2 = g.binary(Binary::Add, x2, y2).unwrap();
        let circle = g.binary(Binary::Sub, r2, l2).unwrap();
        let a = g.binary(Binary::Mul, x, yd).unwrap();
        let b = g.binary(Binary::Mul, y, xd).unwrap();
        let c = g.binary(Binary::Sub, a, b).unwrap();
        let turning = g.binary(Binary::Sub, c, t).unwrap();
        let h = Tape::new(&g, &[circle], Inputs::potential(2, 1), "constraints").unwrap();
        let v = Tape::new(&g, &[turning], Inputs::kinetic(2, 1), "velocity").unwrap();
        let bind = |tape: Tape| Some(Function::new(Arc::new(tape), &[l]).unwrap());
        ExprConstraints::new(2, bind(h), bind(v), vec!["rod".into(), "turn".into()]).unwrap()
    }

    #[test]
    fn jacobian_and_bias_are_exact() {
        let c = rows(2.0);
        assert_eq!((c.holonomic_count(), c.velocity_count()), (1, 1));
        assert!(c.depends_on_time());
        assert_eq!(
            (c.name(0), c.name(1)),
            ("rod".to_string(), "turn".to_string())
        );
        let system = Constrained::new(System::new(2, Point), c);
        let (q, qd) = ([1.2, -1.6], [0.8, 0.6]);
        let g = system.constraint_jacobian(0.5, &q, &qd).unwrap();
        // ∂g/∂q = 2(x, y); ∂(x ẏ − y ẋ − t)/∂q̇ = (−y, x).
        assert_eq!(
            g.row(0).iter().copied().collect::<Vec<_>>(),
            vec![2.4, -3.2]
        );
        assert_eq!(g.row(1).iter().copied().collect::<Vec<_>>(), vec![1.6, 1.2]);
        let gamma = system.gamma(0.5, &q, &qd).unwrap();
        // γ₀ = 2|q̇|²; γ₁ = d/ds (x ẏ − y ẋ − t) along (t + s, q + s q̇) = ẋẏ − ẏẋ − 1.
        assert!((gamma[0] - 2.0).abs() < 1e-15 && (gamma[1] + 1.0).abs() < 1e-15);
        // Rebinding l moves the circle.
        let longer = system.constraints().with_parameters(&[3.0]).unwrap();
        let mut out = [0.0];
        longer.holonomic(0.0, &[3.0, 0.0], &mut out);
        assert_eq!(out[0], 0.0);
    }

    #[test]
    fn bad_rows_are_refused() {
        let mut g = Graph::new();
        let xd = g.velocity(0);
        let tape = Tape::new(&g, &[xd], Inputs::kinetic(1, 0), "constraints").unwrap();
        let f = Function::new(Arc::new(tape), &[]).unwrap();
        let e = ExprConstraints::new(1, Some(f.clone()), None, Vec::new()).unwrap_err();
        assert!(e.to_string().contains("may not read the velocities"), "{e}");
        let e = ExprConstraints::new(2, None, Some(f.clone()), Vec::new()).unwrap_err();
        assert!(
            e.to_string().contains("1 coordinates for a model of 2"),
            "{e}"
        );
        let e = ExprConstraints::new(1, None, Some(f), vec!["a".into(), "b".into()]).unwrap_err();
        assert!(e.to_string().contains("2 names for 1"), "{e}");
        assert!(ExprConstraints::new(1, None, None, Vec::new()).is_err());
    }
}
