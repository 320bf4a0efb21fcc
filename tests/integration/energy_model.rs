//! The energy route of a model stated at run time ([`EnergyModel`]) against the closed forms of
//! the ready-made scenes (moved here from the crate's inline tests, which must not reach up to
//! the scenes).

use approx::assert_relative_eq;
use lagrangian::Dynamics;
use lagrangian::scenes::{DoublePendulum, DrivenPendulum};
use lagrangian::tape::{Binary, EnergyModel, Function, Graph, Inputs, Tape, Unary, models};
use std::sync::Arc;

/// A little expression builder over a [`Graph`] for the tests.
struct B(Graph);
impl B {
    fn c(&mut self, x: f64) -> usize {
        self.0.constant(x)
    }
    fn p(&mut self, i: usize) -> usize {
        self.0.param(i)
    }
    fn bin(&mut self, f: Binary, a: usize, b: usize) -> usize {
        self.0.binary(f, a, b).unwrap()
    }
    fn un(&mut self, f: Unary, a: usize) -> usize {
        self.0.unary(f, a).unwrap()
    }
    fn mul(&mut self, a: usize, b: usize) -> usize {
        self.bin(Binary::Mul, a, b)
    }
    fn add(&mut self, a: usize, b: usize) -> usize {
        self.bin(Binary::Add, a, b)
    }
    fn sub(&mut self, a: usize, b: usize) -> usize {
        self.bin(Binary::Sub, a, b)
    }
    fn sqr(&mut self, a: usize) -> usize {
        self.0.powi(a, 2).unwrap()
    }
    fn function(&self, root: usize, inputs: Inputs, params: &[f64]) -> Function {
        self.outputs(&[root], inputs, params)
    }
    fn outputs(&self, roots: &[usize], inputs: Inputs, params: &[f64]) -> Function {
        let tape = Tape::new(&self.0, roots, inputs, "test").unwrap();
        Function::new(Arc::new(tape), params).unwrap()
    }
}

/// The double pendulum of [`models::double_pendulum`]: parameters (m1, m2, l1, l2, g).
fn double_pendulum(params: &[f64]) -> EnergyModel {
    let mut g = Graph::new();
    let parts = models::double_pendulum(&mut g).unwrap();
    let b = B(g);
    EnergyModel::new(
        2,
        b.function(parts.kinetic, Inputs::kinetic(2, 5), params),
        Some(b.function(parts.potential.unwrap(), Inputs::potential(2, 5), params)),
        None,
        None,
    )
    .unwrap()
}

#[test]
fn energy_model_double_pendulum_matches_closed_form() {
    let p = [1.3, 0.7, 1.1, 0.8, 9.81];
    let model = double_pendulum(&p);
    assert!(model.is_fused());
    let scene = DoublePendulum::new(p[0], p[1], p[2], p[3], p[4]);
    for (q, qd) in [
        ([0.3, -0.4], [0.0, 0.0]),
        ([1.0, 0.5], [0.3, -0.2]),
        ([-2.0, 2.5], [3.0, -4.0]),
    ] {
        let want = scene.closed_form_accelerations(&q, &qd);
        let fused = model.accelerations(0.0, &q, &qd).unwrap();
        let generic = model.system().accelerations(0.0, &q, &qd).unwrap();
        for i in 0..2 {
            assert_relative_eq!(fused[i], want[i], max_relative = 1e-12);
            assert_relative_eq!(generic[i], want[i], max_relative = 1e-12);
        }
    }
}

#[test]
fn energy_model_driven_pendulum_with_damping_and_forcing() {
    // The driven pendulum (T depends on t) plus Φ = ½ c θ̇² and Q = F cos(ν t):
    // m l² θ̈ = m l² θ̈_closed − c θ̇ + F cos(ν t).
    let (m, l, g, a, w, c, f, nu) = (0.9, 1.2, 9.81, 0.3, 5.0, 0.4, 1.5, 2.0);
    let p = [m, l, g, a, w, c, f, nu];
    let mut b = B(Graph::new());
    let (pm, pl, pg, pa, pw, pc, pf, pnu) = (
        b.p(0),
        b.p(1),
        b.p(2),
        b.p(3),
        b.p(4),
        b.p(5),
        b.p(6),
        b.p(7),
    );
    let (th, v, t) = (b.0.coord(0), b.0.velocity(0), b.0.time());
    let s = b.un(Unary::Sin, th);
    let co = b.un(Unary::Cos, th);
    let wt = b.mul(pw, t);
    let swt = b.un(Unary::Sin, wt);
    let cwt = b.un(Unary::Cos, wt);
    let vx = b.mul(co, v);
    let vx = b.mul(vx, pl);
    let vy = b.mul(s, v);
    let vy = b.mul(vy, pl);
    let drive = b.mul(pa, pw);
    let drive = b.mul(drive, swt);
    let vy = b.sub(vy, drive);
    let vx2 = b.sqr(vx);
    let vy2 = b.sqr(vy);
    let v2 = b.add(vx2, vy2);
    let half = b.c(0.5);
    let hm = b.mul(half, pm);
    let kinetic = b.mul(hm, v2);
    let yp = b.mul(pa, cwt);
    let lc = b.mul(pl, co);
    let h = b.sub(yp, lc);
    let mg = b.mul(pm, pg);
    let potential = b.mul(mg, h);
    let v2d = b.sqr(v);
    let hc = b.mul(half, pc);
    let dissipation = b.mul(hc, v2d);
    let nut = b.mul(pnu, t);
    let cnt = b.un(Unary::Cos, nut);
    let force = b.mul(pf, cnt);
    let (ki, po) = (Inputs::kinetic(1, 8), Inputs::potential(1, 8));
    let model = EnergyModel::new(
        1,
        b.function(kinetic, ki, &p),
        Some(b.function(potential, po, &p)),
        Some(b.function(dissipation, ki, &p)),
        Some(b.function(force, ki, &p)),
    )
    .unwrap();
    assert!(model.is_fused());
    let s = model.structure();
    assert!(s.time_dependent && s.dissipative && s.forced);
    // M = m l² (cos²θ + sin²θ) is constant, but the tape cannot know that identity: it says
    // "not constant", the safe answer.
    assert!(!s.constant_mass);
    let scene = DrivenPendulum::new(m, l, g, a, w);
    for (t, q, qd) in [(0.0, 0.3, 0.0), (0.37, -1.1, 2.0), (2.5, 2.9, -0.6)] {
        let want = scene.closed_form_accelerations(t, &[q], &[qd])[0]
            + (-c * qd + f * (nu * t).cos()) / (m * l * l);
        let fused = model.accelerations(t, &[q], &[qd]).unwrap()[0];
        let generic = model.system().accelerations(t, &[q], &[qd]).unwrap()[0];
        assert_relative_eq!(fused, want, max_relative = 1e-12);
        assert_relative_eq!(generic, want, max_relative = 1e-12);
    }
}
