//! Example models stated by program on a [`Graph`]: the double pendulum and a chain of n
//! pendulums, written once here so that the tests, the timings and users building their own
//! models start from the same graphs.
//!
//! Each function adds its nodes to the graph and returns the [`Energies`] (T and U) as nodes;
//! compile them with [`Tape::new`](crate::tape::Tape::new) or [`EomProgram`](crate::tape::EomProgram).
//!
//! ```
//! use lagrangian::tape::{Function, Graph, Inputs, Tape, models};
//! # use approx::assert_relative_eq;
//! let mut g = Graph::new();
//! let energies = models::double_pendulum(&mut g)?;
//! let params = [1.0, 2.0, 1.5, 0.7, 9.81]; // m₁, m₂, l₁, l₂, g
//! let t = Tape::new(&g, &[energies.kinetic], Inputs::kinetic(2, 5), "T")?;
//! let t = Function::new(t.into(), &params)?;
//! let (q, qd) = ([0.3, -0.2], [1.0, 0.5]);
//! let want = 0.5 * 3.0 * 1.5_f64.powi(2) * 1.0
//!     + 0.5 * 2.0 * 0.7_f64.powi(2) * 0.25
//!     + 2.0 * 1.5 * 0.7 * 1.0 * 0.5 * 0.5_f64.cos();
//! assert_relative_eq!(t.eval(0.0, &q, &qd), want, max_relative = 1e-14);
//! # Ok::<(), lagrangian::Error>(())
//! ```

use super::eom_program::Energies;
use crate::error::Result;
use crate::expr::graph::{Binary, Graph, Unary};

/// The double pendulum in its textbook form, parameters (m₁, m₂, l₁, l₂, g):
/// T = ½ (m₁ + m₂) l₁² θ̇₁² + ½ m₂ l₂² θ̇₂² + m₂ l₁ l₂ θ̇₁ θ̇₂ cos(θ₁ − θ₂),
/// U = −g ((m₁ + m₂) l₁ cos θ₁ + m₂ l₂ cos θ₂).
pub fn double_pendulum(g: &mut Graph) -> Result<Energies> {
    let (m1, m2, l1, l2, grav) = (g.param(0), g.param(1), g.param(2), g.param(3), g.param(4));
    let (th1, th2, w1, w2) = (g.coord(0), g.coord(1), g.velocity(0), g.velocity(1));
    let half = g.constant(0.5);
    let m12 = g.binary(Binary::Add, m1, m2)?;
    let l1s = g.powi(l1, 2)?;
    let l2s = g.powi(l2, 2)?;
    let w1s = g.powi(w1, 2)?;
    let w2s = g.powi(w2, 2)?;
    let a = g.binary(Binary::Mul, m12, l1s)?;
    let a = g.binary(Binary::Mul, a, w1s)?;
    let c = g.binary(Binary::Mul, m2, l2s)?;
    let c = g.binary(Binary::Mul, c, w2s)?;
    let s = g.binary(Binary::Add, a, c)?;
    let s = g.binary(Binary::Mul, half, s)?;
    let d = g.binary(Binary::Sub, th1, th2)?;
    let cd = g.unary(Unary::Cos, d)?;
    let mut x = g.binary(Binary::Mul, m2, l1)?;
    for f in [l2, w1, w2, cd] {
        x = g.binary(Binary::Mul, x, f)?;
    }
    let kinetic = g.binary(Binary::Add, s, x)?;
    let c1 = g.unary(Unary::Cos, th1)?;
    let c2 = g.unary(Unary::Cos, th2)?;
    let u1 = g.binary(Binary::Mul, m12, l1)?;
    let u1 = g.binary(Binary::Mul, u1, c1)?;
    let u2 = g.binary(Binary::Mul, m2, l2)?;
    let u2 = g.binary(Binary::Mul, u2, c2)?;
    let u = g.binary(Binary::Add, u1, u2)?;
    let u = g.binary(Binary::Mul, grav, u)?;
    let potential = g.unary(Unary::Neg, u)?;
    Ok(Energies {
        kinetic,
        potential: Some(potential),
        ..Energies::default()
    })
}

/// The double pendulum with equal masses and lengths as `benches/python_vs_rust.py` writes it,
/// parameters (m, l, g): T = ½ m l² (2 θ̇₁² + θ̇₂² + 2 θ̇₁ θ̇₂ cos(θ₁ − θ₂)),
/// U = −m g l (2 cos θ₁ + cos θ₂). The same motion as [`double_pendulum`] with m₁ = m₂, l₁ = l₂,
/// as a different graph (what a Python user's expressions compile to).
pub fn double_pendulum_equal(g: &mut Graph) -> Result<Energies> {
    let (m, l, grav) = (g.param(0), g.param(1), g.param(2));
    let (th1, th2, w1, w2) = (g.coord(0), g.coord(1), g.velocity(0), g.velocity(1));
    let (half, two) = (g.constant(0.5), g.constant(2.0));
    let l2 = g.powi(l, 2)?;
    let k = g.binary(Binary::Mul, half, m)?;
    let k = g.binary(Binary::Mul, k, l2)?;
    let w1s = g.powi(w1, 2)?;
    let w2s = g.powi(w2, 2)?;
    let a = g.binary(Binary::Mul, two, w1s)?;
    let a = g.binary(Binary::Add, a, w2s)?;
    let d = g.binary(Binary::Sub, th1, th2)?;
    let c = g.unary(Unary::Cos, d)?;
    let x = g.binary(Binary::Mul, two, w1)?;
    let x = g.binary(Binary::Mul, x, w2)?;
    let x = g.binary(Binary::Mul, x, c)?;
    let a = g.binary(Binary::Add, a, x)?;
    let kinetic = g.binary(Binary::Mul, k, a)?;
    let mgl = g.binary(Binary::Mul, m, grav)?;
    let mgl = g.binary(Binary::Mul, mgl, l)?;
    let c1 = g.unary(Unary::Cos, th1)?;
    let c2 = g.unary(Unary::Cos, th2)?;
    let c1 = g.binary(Binary::Mul, two, c1)?;
    let s = g.binary(Binary::Add, c1, c2)?;
    let u = g.binary(Binary::Mul, mgl, s)?;
    let potential = g.unary(Unary::Neg, u)?;
    Ok(Energies {
        kinetic,
        potential: Some(potential),
        ..Energies::default()
    })
}

/// A chain of n pendulums of mass m and length l, parameters (m, l, g), with the Cartesian
/// velocities as running sums: vₖ = Σ_{j≤k} l θ̇ⱼ (cos θⱼ, sin θⱼ), yₖ = −Σ_{j≤k} l cos θⱼ,
/// T = ½ m Σₖ |vₖ|², U = m g Σₖ yₖ. Its mass matrix is not constant.
pub fn pendulum_chain(g: &mut Graph, n: usize) -> Result<Energies> {
    let (m, l, grav) = (g.param(0), g.param(1), g.param(2));
    let half = g.constant(0.5);
    let (mut vx, mut vy, mut y, mut kin, mut pot) = (None, None, None, None, None);
    let acc = |g: &mut Graph, a: Option<usize>, x: usize| match a {
        None => Ok(x),
        Some(a) => g.binary(Binary::Add, a, x),
    };
    for i in 0..n {
        let (th, w) = (g.coord(i), g.velocity(i));
        let (s, c) = (g.unary(Unary::Sin, th)?, g.unary(Unary::Cos, th)?);
        let lw = g.binary(Binary::Mul, l, w)?;
        let dx = g.binary(Binary::Mul, lw, c)?;
        let dy = g.binary(Binary::Mul, lw, s)?;
        let x = acc(g, vx, dx)?;
        let yv = acc(g, vy, dy)?;
        (vx, vy) = (Some(x), Some(yv));
        let lc = g.binary(Binary::Mul, l, c)?;
        let h = g.unary(Unary::Neg, lc)?;
        let yk = acc(g, y, h)?;
        y = Some(yk);
        let v2x = g.powi(x, 2)?;
        let v2y = g.powi(yv, 2)?;
        let v2 = g.binary(Binary::Add, v2x, v2y)?;
        kin = Some(acc(g, kin, v2)?);
        pot = Some(acc(g, pot, yk)?);
    }
    let (kin, pot) = match (kin, pot) {
        (Some(k), Some(p)) => (k, p),
        _ => {
            let zero = g.constant(0.0);
            (zero, zero)
        }
    };
    let hm = g.binary(Binary::Mul, half, m)?;
    let kinetic = g.binary(Binary::Mul, hm, kin)?;
    let mg = g.binary(Binary::Mul, m, grav)?;
    let potential = g.binary(Binary::Mul, mg, pot)?;
    Ok(Energies {
        kinetic,
        potential: Some(potential),
        ..Energies::default()
    })
}
