//! Taylor expansions of models derived on the graph against the same models through the tapes'
//! dual numbers and against an integration (moved from the crate's inline tests, which must not
//! reach up to the integrators).

use lagrangian::tape::{
    Binary, Energies, EnergyModel, Function, Graph, Inputs, Tape, TaylorProgram, Unary, eom_graph,
    models,
};
use lagrangian::{Method, Options, solve};
use std::sync::Arc;

/// M, f derived from `parts` on `g`, its expansion program, and the same model through the
/// tapes' dual numbers (the reference the coefficients are checked against).
fn setup(
    g: &mut Graph,
    dof: usize,
    parts: &Energies,
    params: &[f64],
) -> (TaylorProgram, EnergyModel) {
    let eom = eom_graph(g, dof, parts).unwrap();
    let program = TaylorProgram::new(g, eom.dof, &eom.mass, &eom.force);
    let f = |nodes: &[usize], inputs: Inputs| {
        Function::new(
            Arc::new(Tape::new(g, nodes, inputs, "part").unwrap()),
            params,
        )
        .unwrap()
    };
    let all = Inputs::kinetic(dof, params.len());
    let model = EnergyModel::new(
        dof,
        f(&[parts.kinetic], all),
        parts
            .potential
            .map(|u| f(&[u], Inputs::potential(dof, params.len()))),
        parts.dissipation.map(|r| f(&[r], all)),
        parts.forces.as_ref().map(|q| f(q, all)),
    )
    .unwrap();
    (program, model)
}

/// A scaling by a constant that reads a parameter stays, whatever the parameter: U =
/// sign(p) x²/2 gives ẍ = −sign(p) x, a scaling by −½ · 2 · sign(p), which is 1 for p < 0
/// only (and which sign(NaN) = −1 would take for 1), for p = ±2.
#[test]
fn scalings_by_parameters_stay() {
    let mut g = Graph::new();
    let (x, v, p) = (g.coord(0), g.velocity(0), g.param(0));
    let half = g.constant(0.5);
    let v2 = g.powi(v, 2).unwrap();
    let x2 = g.powi(x, 2).unwrap();
    let sign = g.unary(Unary::Sign, p).unwrap();
    let scaled = g.binary(Binary::Mul, sign, x2).unwrap();
    let parts = Energies {
        kinetic: g.binary(Binary::Mul, half, v2).unwrap(),
        potential: Some(g.binary(Binary::Mul, half, scaled).unwrap()),
        dissipation: None,
        forces: None,
    };
    for p in [2.0, -2.0] {
        let (program, _) = setup(&mut g, 1, &parts, &[p]);
        let mut e = Arc::new(program).expansion(&[p], 4);
        e.expand(0.0, &[1.0], &[0.0]).unwrap();
        // q̇'s coefficient 1 is q̈₀ = −sign(p) x₀.
        assert_eq!(e.qd(1)[0], -p.signum(), "p = {p}");
    }
}

/// x = cos t from (1, 0) under T = ½ẋ², U = ½x²: xₖ = cos⁽ᵏ⁾(0)/k!.
#[test]
fn oscillator_coefficients_are_those_of_cos() {
    let mut g = Graph::new();
    let (x, v, half) = (g.coord(0), g.velocity(0), g.constant(0.5));
    let v2 = g.powi(v, 2).unwrap();
    let x2 = g.powi(x, 2).unwrap();
    let parts = Energies {
        kinetic: g.binary(Binary::Mul, half, v2).unwrap(),
        potential: Some(g.binary(Binary::Mul, half, x2).unwrap()),
        dissipation: None,
        forces: None,
    };
    let (program, _) = setup(&mut g, 1, &parts, &[]);
    let program = Arc::new(program);
    let mut e = program.expansion(&[], 24);
    e.expand(0.0, &[1.0], &[0.0]).unwrap();
    let mut factorial = 1.0;
    for k in 0..=24 {
        if k > 0 {
            factorial *= k as f64;
        }
        let want = match k % 4 {
            0 => 1.0,
            2 => -1.0,
            _ => 0.0,
        } / factorial;
        // A rounding or two per order on each side (the product by 1/k here, the
        // factorial there): measured 4.6e-16 at worst (k = 24).
        assert!(
            (e.q(k)[0] - want).abs() <= 8e-16 * want.abs(),
            "{k}: {} vs {want}",
            e.q(k)[0]
        );
    }
}

#[test]
fn expansion_agrees_with_an_integration_for_every_function() {
    let mut g = Graph::new();
    let (x, v, t, p) = (g.coord(0), g.velocity(0), g.time(), g.param(0));
    let c = |g: &mut Graph, k: f64| g.constant(k);
    let mul = |g: &mut Graph, a: usize, b: usize| g.binary(Binary::Mul, a, b).unwrap();
    let add = |g: &mut Graph, a: usize, b: usize| g.binary(Binary::Add, a, b).unwrap();
    let un = |g: &mut Graph, f: Unary, a: usize| g.unary(f, a).unwrap();
    // T = ½ (2 + ½ sin x) ẋ² + 0.1 t x ẋ
    let s = un(&mut g, Unary::Sin, x);
    let (half, two) = (c(&mut g, 0.5), c(&mut g, 2.0));
    let hs = mul(&mut g, half, s);
    let m = add(&mut g, two, hs);
    let v2 = g.powi(v, 2).unwrap();
    let mv = mul(&mut g, m, v2);
    let kin = mul(&mut g, half, mv);
    let tenth = c(&mut g, 0.1);
    let tx = mul(&mut g, t, x);
    let txv = mul(&mut g, tx, v);
    let gyro = mul(&mut g, tenth, txv);
    let kinetic = add(&mut g, kin, gyro);
    // U = ½ p x² + 0.01 Σ (every function of x)
    let x2 = g.powi(x, 2).unwrap();
    let px2 = mul(&mut g, p, x2);
    let mut u = mul(&mut g, half, px2);
    let mut terms = Vec::new();
    let k03 = c(&mut g, 0.3);
    let x03 = mul(&mut g, k03, x);
    terms.push(un(&mut g, Unary::Tan, x03));
    terms.push(un(&mut g, Unary::Exp, x03));
    let x2p = add(&mut g, two, x);
    terms.push(un(&mut g, Unary::Ln, x2p));
    terms.push(un(&mut g, Unary::Sqrt, x2p));
    terms.push(un(&mut g, Unary::Sinh, x03));
    terms.push(un(&mut g, Unary::Cosh, x03));
    terms.push(un(&mut g, Unary::Tanh, x));
    terms.push(un(&mut g, Unary::Cos, x03));
    let k17 = c(&mut g, 1.7);
    terms.push(g.binary(Binary::Pow, x2p, k17).unwrap());
    terms.push(g.binary(Binary::Pow, x2p, x03).unwrap());
    terms.push(g.binary(Binary::Atan2, x, two).unwrap());
    terms.push(g.binary(Binary::Atan2, two, x2p).unwrap());
    let five = c(&mut g, 5.0);
    let x5 = add(&mut g, x, five);
    terms.push(un(&mut g, Unary::Abs, x5));
    terms.push(g.powi(x2p, -2).unwrap());
    terms.push(g.powi(x, 3).unwrap());
    let ct = un(&mut g, Unary::Cos, t);
    terms.push(mul(&mut g, ct, x));
    terms.push(g.binary(Binary::Div, x, x2p).unwrap());
    let small = c(&mut g, 0.01);
    for term in terms {
        let st = mul(&mut g, small, term);
        u = add(&mut g, u, st);
    }
    // Φ = 0.05 ẋ², Q = 0.2 sin t
    let k005 = c(&mut g, 0.05);
    let dissipation = Some(mul(&mut g, k005, v2));
    let k02 = c(&mut g, 0.2);
    let st = un(&mut g, Unary::Sin, t);
    let forces = Some(vec![mul(&mut g, k02, st)]);
    let parts = Energies {
        kinetic,
        potential: Some(u),
        dissipation,
        forces,
    };
    let params = [1.3];
    let (program, model) = setup(&mut g, 1, &parts, &params);
    let program = Arc::new(program);
    let (t0, q0, v0) = (0.1, [0.3], [0.2]);
    let mut e = program.expansion(&params, 20);
    e.expand(t0, &q0, &v0).unwrap();
    // Order 2 is half the acceleration.
    let mut a = [0.0];
    lagrangian::Dynamics::accelerations_into(&model, t0, &q0, &v0, &mut a).unwrap();
    assert!((2.0 * e.q(2)[0] - a[0]).abs() < 1e-14 * a[0].abs().max(1.0));
    for h in [0.05, -0.05, 0.1] {
        let options = Options::adaptive(1e-14, 1e-15);
        let sol = solve(&model, &q0, &v0, (t0, t0 + h), Method::Dop853, &options).unwrap();
        let (_, q, qd) = sol.last().unwrap();
        let mut y = [0.0; 2];
        e.eval(h, &mut y);
        assert!((y[0] - q[0]).abs() < 2e-13, "h = {h}: {} vs {}", y[0], q[0]);
        assert!(
            (y[1] - qd[0]).abs() < 2e-12,
            "h = {h}: {} vs {}",
            y[1],
            qd[0]
        );
    }
}

/// The double pendulum (M(q), two coordinates): the expansion summed at h against DOP853.
#[test]
fn double_pendulum_expansion() {
    let mut g = Graph::new();
    let parts = models::double_pendulum(&mut g).unwrap();
    let params = [1.0, 2.0, 1.5, 0.7, 9.81];
    let (program, model) = setup(&mut g, 2, &parts, &params);
    let program = Arc::new(program);
    let (q0, v0) = ([1.0, -0.5], [0.3, 2.0]);
    let mut e = program.expansion(&params, 22);
    e.expand(0.0, &q0, &v0).unwrap();
    let h = 0.05;
    let sol = solve(
        &model,
        &q0,
        &v0,
        (0.0, h),
        Method::Dop853,
        &Options::adaptive(1e-14, 1e-15),
    )
    .unwrap();
    let (_, q, qd) = sol.last().unwrap();
    let mut y = [0.0; 4];
    e.eval(h, &mut y);
    for i in 0..2 {
        assert!((y[i] - q[i]).abs() < 1e-13, "{y:?} vs {q:?}");
        assert!((y[2 + i] - qd[i]).abs() < 1e-12, "{y:?} vs {qd:?}");
    }
}
