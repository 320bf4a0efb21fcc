//! [`ExprConstraints`]: constraints stated as compiled expression tapes, under [`Constrained`]
//! (tested here, the last room: `routes` comes before `constrained`).

use crate::constrained::Constrained;
use crate::derived::constraint_program::ConstraintProgram;
use crate::energies::Constraints;
use crate::energies::KineticEnergy;
use crate::expr::graph::{Binary, Graph};
use crate::program::eval::Function;
use crate::program::{compile::Tape, inputs::Inputs};
use crate::routes::ExprConstraints;
use crate::routes::System;
use crate::scalar::Scalar;
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
    let compiled = ConstraintProgram::new(&mut g, 2, 1, &[circle], &[turning], true).unwrap();
    let h = Tape::new(&g, &[circle], Inputs::potential(2, 1), "constraints").unwrap();
    let v = Tape::new(&g, &[turning], Inputs::kinetic(2, 1), "velocity").unwrap();
    let bind = |tape: Tape| Some(Function::new(Arc::new(tape), &[l]).unwrap());
    ExprConstraints::new(2, bind(h), bind(v), vec!["rod".into(), "turn".into()])
        .unwrap()
        .with_compiled_rows(compiled.bind(&[l]).unwrap())
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
    // The same from the rows derived on the graph and compiled.
    let (mut gc, mut gammac) = ([0.0; 4], [0.0; 2]);
    assert!(
        system
            .constraints()
            .compiled_rows(0.5, &q, &qd, &mut gc, &mut gammac)
    );
    assert_eq!(gc, [2.4, -3.2, 1.6, 1.2]);
    assert!((gammac[0] - 2.0).abs() < 1e-15 && (gammac[1] + 1.0).abs() < 1e-15);
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
