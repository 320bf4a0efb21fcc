//! Every dual number the derivative passes evaluate a tape on takes the jet path (`eval.rs`'s
//! `path` records it), checked through the routes — the energy route and the particle route —
//! that sit above the interpreter: here, so that `program/eval.rs` draws no arrow up to them.

use crate::dynamics::Dynamics;
use crate::error::Result;
use crate::expr::graph::{Binary, Graph, Unary};
use crate::program::compile::Tape;
use crate::program::eval::Function;
use crate::program::inputs::Inputs;
use crate::routes::EnergyModel;
use crate::routes::ParticleSystem;
use crate::routes::TapeParticles;

/// A chain of n pendulums stated as tapes: T (position-dependent, or with a constant M),
/// U, Φ and Q″, each optionally time-dependent; and the same chain as particles.
struct Chain {
    g: Graph,
    kinetic: usize,
    potential: usize,
    dissipation: usize,
    forces: Vec<usize>,
    positions: Vec<usize>,
}

fn chain(n: usize, position: bool, time: bool) -> Result<Chain> {
    let mut g = Graph::new();
    let (half, tenth) = (g.constant(0.5), g.constant(0.1));
    let t = g.time();
    let st = g.unary(Unary::Sin, t)?;
    let one = g.constant(1.0);
    let scale = if time {
        let s = g.binary(Binary::Mul, tenth, st)?;
        g.binary(Binary::Add, one, s)?
    } else {
        one
    };
    let (mut x, mut y) = (None, None);
    let (mut vx, mut vy) = (None, None);
    let (mut kin, mut pot, mut dis) = (half, half, half);
    let (mut forces, mut positions) = (vec![], vec![]);
    let add = |g: &mut Graph, a: Option<usize>, b: usize| match a {
        None => Ok(b),
        Some(a) => g.binary(Binary::Add, a, b),
    };
    for i in 0..n {
        let (th, w) = (g.coord(i), g.velocity(i));
        let (s, c) = (g.unary(Unary::Sin, th)?, g.unary(Unary::Cos, th)?);
        x = Some(add(&mut g, x, s)?);
        let nc = g.unary(Unary::Neg, c)?;
        y = Some(add(&mut g, y, nc)?);
        positions.extend([x.unwrap(), y.unwrap()]);
        let (dx, dy) = if position {
            (g.binary(Binary::Mul, w, c)?, g.binary(Binary::Mul, w, s)?)
        } else {
            let k = g.constant(1.0 + i as f64);
            (g.binary(Binary::Mul, k, w)?, w)
        };
        vx = Some(add(&mut g, vx, dx)?);
        vy = Some(add(&mut g, vy, dy)?);
        let (a, b) = (g.powi(vx.unwrap(), 2)?, g.powi(vy.unwrap(), 2)?);
        let v2 = g.binary(Binary::Add, a, b)?;
        kin = g.binary(Binary::Add, kin, v2)?;
        let h = g.binary(Binary::Mul, scale, y.unwrap())?;
        pot = g.binary(Binary::Add, pot, h)?;
        let w2 = g.powi(w, 2)?;
        dis = g.binary(Binary::Add, dis, w2)?;
        let f = g.binary(Binary::Mul, tenth, th)?;
        forces.push(if time {
            g.binary(Binary::Mul, f, st)?
        } else {
            f
        });
    }
    let kinetic = g.binary(Binary::Mul, scale, kin)?;
    let dissipation = g.binary(Binary::Mul, tenth, dis)?;
    Ok(Chain {
        g,
        kinetic,
        potential: pot,
        dissipation,
        forces,
        positions,
    })
}

/// Every evaluation the engine's methods make at `f64` states.
fn exercise<S: Dynamics>(s: &S) {
    let n = s.dof();
    let q: Vec<f64> = (0..n).map(|i| 0.3 + 0.1 * i as f64).collect();
    let qd: Vec<f64> = (0..n).map(|i| 0.2 - 0.05 * i as f64).collect();
    let (mut v, mut m) = (vec![0.0; n], vec![0.0; n * n]);
    s.accelerations_into(0.1, &q, &qd, &mut v).unwrap();
    s.mass_matrix_into(0.1, &q, &qd, &mut m);
    s.momenta_into(0.1, &q, &qd, &mut v);
    s.potential_gradient_into(0.1, &q, &mut v);
    s.dissipative_forces_into(0.1, &q, &qd, &mut v);
    s.generalized_forces_into(0.1, &q, &qd, &mut v);
    s.energy(0.1, &q, &qd).unwrap();
    s.lagrangian_at(0.1, &q, &qd).unwrap();
}

/// Every dual number the derivative passes evaluate a tape on at `f64` states, for 1 to 6
/// coordinates (one pass, and chunks of CHUNK), with and without t and q in T, through the
/// energy route (plain [`System`](crate::System) and [`EnergyModel`]) and the particle route,
/// takes the jet path: a pass shape missing from `pass_chunks!`/`via_jets!` fails here.
#[test]
fn eval_takes_jet_path_for_every_pass_shape() {
    crate::program::eval::path::take();
    for n in 1..=6 {
        for (position, time) in [(true, false), (true, true), (false, false), (false, true)] {
            let c = chain(n, position, time).unwrap();
            let bind = |outs: &[usize], inputs: Inputs| {
                let tape = Tape::new(&c.g, outs, inputs, "test").unwrap();
                Function::new(tape.into(), &[]).unwrap()
            };
            let (all, no_qd) = (Inputs::kinetic(n, 0), Inputs::potential(n, 0));
            let model = EnergyModel::new(
                n,
                bind(&[c.kinetic], all),
                Some(bind(&[c.potential], no_qd)),
                Some(bind(&[c.dissipation], all)),
                Some(bind(&c.forces, all)),
            )
            .unwrap();
            exercise(&model);
            exercise(model.system());
            let particles =
                TapeParticles::new(n, 2, bind(&c.positions, no_qd), vec![1.0; n]).unwrap();
            let particles = ParticleSystem::new(particles)
                .with_potential(Some(bind(&[c.potential], no_qd)))
                .with_dissipation(Some(bind(&[c.dissipation], all)))
                .with_forces(Some(bind(&c.forces, all)));
            exercise(&particles);
        }
    }
    let (fallbacks, jets) = crate::program::eval::path::take();
    assert!(
        fallbacks.is_empty(),
        "pass shapes evaluated on the generic path: {fallbacks:?}"
    );
    assert!(jets > 0);
}
