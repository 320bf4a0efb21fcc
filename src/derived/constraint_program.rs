//! The constraints' derivatives taken ahead of time on the expression graph: G and γ of
//! Lagrange's equations of the first kind as one program, compiled to machine code where
//! Cranelift serves the host ([`ConstraintProgram`]), so that a constrained model stated as
//! expressions pays no dual-number pass per evaluation — as eq. 55 itself is derived once.
//!
//! For holonomic rows g(t, q): G = ∂g/∂q, one tangent sweep per coordinate, and
//! γ = d²/ds² g(t + s, q + s q̇) at s = 0: the tangent along the motion (q ↦ q̇, t ↦ 1, q̇ held),
//! taken twice. For velocity rows a(t, q)·q̇ + b(t, q): G = ∂/∂q̇ by the same sweeps over q̇, and
//! γ the tangent along the motion once. All by the graph's own forward differentiation
//! ([`tangents`]), never by finite differences.

use crate::error::{Error, Result};
use crate::expr::derive::{Seeds, tangents};
use crate::expr::graph::Graph;
use crate::program::compile::Tape;
use crate::program::eval::Function;
use crate::program::inputs::Inputs;
use crate::scalar::with_f64_buf;
use std::sync::Arc;

/// G (row-major, rows × n) and γ (rows) of a set of constraint rows, as one program over
/// (t, q, q̇) and the parameters: holonomic rows first, then velocity rows.
#[derive(Debug, Clone)]
pub struct ConstraintProgram {
    dof: usize,
    rows: usize,
    tape: Arc<Tape>,
    #[cfg(feature = "jit")]
    native: Option<Arc<crate::native::tape::NativeTape>>,
}

impl ConstraintProgram {
    /// Derive G and γ of the rows `holonomic` (nodes of g(t, q)) and `velocity` (nodes of
    /// a(t, q)·q̇ + b(t, q), linear in q̇) on `graph`, for `dof` coordinates and `params`
    /// parameters, and compile them (machine code with the `jit` feature where the host allows,
    /// the tape interpreter otherwise). `moving`: whether a row reads t (otherwise t is held).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when there are no rows or a node is not in the graph; the
    /// compiler's errors.
    pub fn new(
        graph: &mut Graph,
        dof: usize,
        params: usize,
        holonomic: &[usize],
        velocity: &[usize],
        moving: bool,
    ) -> Result<Self> {
        let rows = holonomic.len() + velocity.len();
        if rows == 0 || dof == 0 {
            return Err(Error::InvalidInput {
                what: "constraints",
                why: "a constraint program needs at least one row and one coordinate".into(),
            });
        }
        let (g, gamma, _) = constraint_graph(graph, dof, holonomic, velocity, moving)?;
        let outputs: Vec<usize> = g.into_iter().chain(gamma).collect();
        let tape = Arc::new(Tape::new(
            graph,
            &outputs,
            Inputs::kinetic(dof, params),
            "constraint rows",
        )?);
        #[cfg(feature = "jit")]
        let native = crate::native::tape::NativeTape::compile(&tape)
            .ok()
            .map(Arc::new);
        Ok(Self {
            dof,
            rows,
            tape,
            #[cfg(feature = "jit")]
            native,
        })
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// What runs it: `"native"` or `"interpreter"`.
    pub fn backend(&self) -> &'static str {
        #[cfg(feature = "jit")]
        if self.native.is_some() {
            return "native";
        }
        "interpreter"
    }

    /// The program bound to parameter values.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when `params` has the wrong length.
    pub fn bind(&self, params: &[f64]) -> Result<ConstraintRows> {
        Ok(ConstraintRows {
            program: self.clone(),
            function: Function::new(self.tape.clone(), params)?,
        })
    }
}

/// A [`ConstraintProgram`] bound to parameter values: G and γ at a state.
#[derive(Debug, Clone)]
pub struct ConstraintRows {
    program: ConstraintProgram,
    function: Function,
}

impl ConstraintRows {
    /// The same program with other parameter values.
    ///
    /// # Errors
    /// As [`ConstraintProgram::bind`].
    pub fn with_parameters(&self, params: &[f64]) -> Result<Self> {
        self.program.bind(params)
    }

    /// The program.
    pub fn program(&self) -> &ConstraintProgram {
        &self.program
    }

    /// G (row-major, rows × n) into `g` and γ into `gamma` at (t, q, q̇).
    ///
    /// # Panics
    /// If a slice has the wrong length.
    pub fn eval(&self, t: f64, q: &[f64], qd: &[f64], g: &mut [f64], gamma: &mut [f64]) {
        let (n, k) = (self.program.dof, self.program.rows);
        assert!(q.len() == n && qd.len() == n, "wrong state lengths");
        assert!(g.len() == k * n && gamma.len() == k, "wrong output lengths");
        with_f64_buf::<256, _>(k * n + k, |out| {
            #[cfg(feature = "jit")]
            if let Some(native) = &self.program.native {
                native.eval(self.function.constants(), t, q, qd, out);
            } else {
                self.function.eval_into(t, q, qd, out);
            }
            #[cfg(not(feature = "jit"))]
            self.function.eval_into(t, q, qd, out);
            g.copy_from_slice(&out[..k * n]);
            gamma.copy_from_slice(&out[k * n..]);
        });
    }
}

/// G (row-major, rows × `dof`) and γ of the rows `holonomic` and `velocity` as nodes of
/// `graph` (see the module docs), holonomic rows first, and the rows at the velocity level
/// (ġ of the holonomic rows, then the velocity rows); `moving`: whether a row reads t.
///
/// # Errors
/// As [`tangents`].
pub(crate) fn constraint_graph(
    graph: &mut Graph,
    dof: usize,
    holonomic: &[usize],
    velocity: &[usize],
    moving: bool,
) -> Result<(Vec<usize>, Vec<usize>, Vec<usize>)> {
    let rows = holonomic.len() + velocity.len();
    let zero = graph.constant(0.0);
    let one = graph.constant(1.0);
    let or_zero = |d: Vec<Option<usize>>| d.into_iter().map(|x| x.unwrap_or(zero)).collect();
    // G, column by column.
    let mut g = vec![zero; rows * dof];
    for j in 0..dof {
        let hol: Vec<usize> = or_zero(tangents(graph, holonomic, &Seeds::new().coord(j, one))?);
        let vel: Vec<usize> = or_zero(tangents(graph, velocity, &Seeds::new().velocity(j, one))?);
        for (i, &d) in hol.iter().chain(&vel).enumerate() {
            g[i * dof + j] = d;
        }
    }
    // Along the motion with q̈ = 0: q ↦ q̇, t ↦ 1 (or held).
    let mut along = Seeds::new();
    for i in 0..dof {
        let v = graph.velocity(i);
        along = along.coord(i, v);
    }
    if moving {
        along = along.time(one);
    }
    let rate: Vec<usize> = or_zero(tangents(graph, holonomic, &along)?);
    let mut gamma: Vec<usize> = or_zero(tangents(graph, &rate, &along)?);
    gamma.extend(or_zero(tangents(graph, velocity, &along)?));
    let level1 = rate.into_iter().chain(velocity.iter().copied()).collect();
    Ok((g, gamma, level1))
}
