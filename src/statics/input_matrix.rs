//! The input matrix B = ∂ẋ/∂u of a linearization, for inputs u that are parameters of a model
//! stated on the expression graph: exact, by differentiation on the graph.
//!
//! From M q̈ = f (eq. 55), along a parameter u: M ∂q̈/∂u = ∂f/∂u − (∂M/∂u) q̈. One tangent sweep
//! of M's upper triangle and f per input (seed u ↦ 1, [`Seeds::param`]), compiled into one tape,
//! evaluated at the operating point and solved with M there. A parameter may enter anywhere: a
//! generalized force, the potential, or M itself (a mass).

use crate::derived::eom_program::{Energies, eom_graph};
use crate::error::{Error, Result};
use crate::expr::derive::{Seeds, tangents};
use crate::expr::graph::Graph;
use crate::program::compile::Tape;
use crate::program::eval::Function;
use crate::program::inputs::Inputs;
use crate::statics::Linearization;
use nalgebra::DMatrix;
use std::sync::Arc;

/// B = ∂ẋ/∂u (2n × k, x = (q, q̇)) at the operating point of `lin`, for the parameters whose
/// indices are `inputs`, of the model whose energies are `parts` (nodes of `graph`) bound to the
/// parameter values `params`. The rows of q are zero; the rows of q̇ are ∂q̈/∂uⱼ, column j.
///
/// `lin` must be the linearization of that model at those values (its M and q̈ are used).
///
/// # Errors
/// [`Error::InvalidInput`] when an input is not a parameter; as [`eom_graph`] and [`Tape::new`]
/// for bad parts; [`Error::SingularMassMatrix`] where M cannot be factored; [`Error::NonFinite`]
/// when a derivative is not finite.
pub fn input_matrix(
    graph: &Graph,
    parts: &Energies,
    params: &[f64],
    inputs: &[usize],
    lin: &Linearization,
) -> Result<DMatrix<f64>> {
    let n = lin.q.len();
    if let Some(&i) = inputs.iter().find(|&&i| i >= params.len()) {
        return Err(Error::InvalidInput {
            what: "inputs",
            why: format!(
                "input {i} is not a parameter: the model has {} parameters",
                params.len()
            ),
        });
    }
    // Deriving again on a copy finds the nodes the model's program was compiled from (the graph
    // stores equal nodes once) and adds only the tangents.
    let mut g = graph.clone();
    let eom = eom_graph(&mut g, n, parts)?;
    let (one, zero) = (g.constant(1.0), g.constant(0.0));
    let roots: Vec<usize> = eom.mass.iter().chain(&eom.force).copied().collect();
    let mut outputs = Vec::with_capacity(roots.len() * inputs.len());
    for &i in inputs {
        let d = tangents(&mut g, &roots, &Seeds::new().param(i, one))?;
        outputs.extend(d.into_iter().map(|x| x.unwrap_or(zero)));
    }
    let b = DMatrix::zeros(2 * n, inputs.len());
    if inputs.is_empty() {
        return Ok(b);
    }
    let tape = Tape::new(
        &g,
        &outputs,
        Inputs::kinetic(n, params.len()),
        "input matrix",
    )?;
    let function = Function::new(Arc::new(tape), params)?;
    let mut values = vec![0.0; outputs.len()];
    function.eval_into(lin.t, lin.q.as_slice(), lin.qd.as_slice(), &mut values);
    let mut factor: Vec<f64> = lin.m.transpose().iter().copied().collect();
    crate::linalg::factor_mass(&mut factor, n, lin.t, lin.q.as_slice())?;
    let triangle = n * (n + 1) / 2;
    let mut b = b;
    for (j, column) in values.chunks_exact(roots.len()).enumerate() {
        let (dm, df) = column.split_at(triangle);
        // ∂f/∂u − (∂M/∂u) q̈, with ∂M/∂u symmetric from its upper triangle row by row.
        let mut rhs = df.to_vec();
        let mut k = 0;
        for r in 0..n {
            for c in r..n {
                rhs[r] -= dm[k] * lin.accelerations[c];
                if c != r {
                    rhs[c] -= dm[k] * lin.accelerations[r];
                }
                k += 1;
            }
        }
        crate::linalg::solve_mass(&factor, n, lin.t, &mut rhs)?;
        for (r, x) in rhs.into_iter().enumerate() {
            b[(n + r, j)] = x;
        }
    }
    Ok(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::graph::{Binary, Unary};
    use crate::routes::EnergyModel;
    use approx::assert_relative_eq;

    /// A pendulum with a torque F: T = ½ m l² θ̇², U = −m g l cos θ, Q = F; parameters
    /// (m, g, l, F), so q̈ = F/(m l²) − (g/l) sin θ.
    #[test]
    fn pendulum_input_matrix_is_the_closed_form() {
        let mut g = Graph::new();
        let (m, grav, l, f) = (g.param(0), g.param(1), g.param(2), g.param(3));
        let (th, thd) = (g.coord(0), g.velocity(0));
        let half = g.constant(0.5);
        let ll = g.binary(Binary::Mul, l, l).unwrap();
        let mll = g.binary(Binary::Mul, m, ll).unwrap();
        let v2 = g.binary(Binary::Mul, thd, thd).unwrap();
        let hv = g.binary(Binary::Mul, half, v2).unwrap();
        let kinetic = g.binary(Binary::Mul, mll, hv).unwrap();
        let c = g.unary(Unary::Cos, th).unwrap();
        let mg = g.binary(Binary::Mul, m, grav).unwrap();
        let mgl = g.binary(Binary::Mul, mg, l).unwrap();
        let mglc = g.binary(Binary::Mul, mgl, c).unwrap();
        let potential = g.unary(Unary::Neg, mglc).unwrap();
        let parts = Energies {
            kinetic,
            potential: Some(potential),
            dissipation: None,
            forces: Some(vec![f]),
        };
        let params = [2.0, 9.81, 0.7, 1.5];
        let tape = |root: &[usize], inputs: Inputs| {
            Function::new(
                Arc::new(Tape::new(&g, root, inputs, "part").unwrap()),
                &params,
            )
            .unwrap()
        };
        let model = EnergyModel::new(
            1,
            tape(&[kinetic], Inputs::kinetic(1, 4)),
            Some(tape(&[potential], Inputs::potential(1, 4))),
            None,
            Some(tape(&[f], Inputs::kinetic(1, 4))),
        )
        .unwrap();
        let (theta, omega) = (0.4_f64, -1.3);
        let lin = crate::statics::linearize(&model, 0.0, &[theta], &[omega]).unwrap();
        let b = input_matrix(&g, &parts, &params, &[3, 1, 0, 2], &lin).unwrap();
        let [m, grav, l, f] = params;
        assert_eq!(b.shape(), (2, 4));
        assert_eq!(b.row(0).iter().copied().collect::<Vec<_>>(), vec![0.0; 4]);
        assert_relative_eq!(b[(1, 0)], 1.0 / (m * l * l), epsilon = 1e-14);
        assert_relative_eq!(b[(1, 1)], -theta.sin() / l, epsilon = 1e-14);
        // m enters M: −(∂M/∂m) q̈ / M.
        assert_relative_eq!(b[(1, 2)], -f / (m * m * l * l), epsilon = 1e-14);
        let dl = -2.0 * f / (m * l * l * l) + grav * theta.sin() / (l * l);
        assert_relative_eq!(b[(1, 3)], dl, epsilon = 1e-13);
        assert!(matches!(
            input_matrix(&g, &parts, &params, &[4], &lin),
            Err(Error::InvalidInput { .. })
        ));
    }
}
