//! The Taylor lowering checked on models derived on the graph, against the same models through
//! the tapes' dual numbers: they read the lowering's crate-private rows and reach up to the
//! derived models and the routes, so they live in this room above both, not inline in
//! `crate::taylor` (those that need only the public API are in
//! `tests/integration/taylor_series.rs`).

use crate::derived::eom_program::{Energies, eom_graph};
use crate::dynamics::Dynamics;
use crate::expr::graph::{Binary, Graph, Unary};
use crate::program::compile::Tape;
use crate::program::eval::Function;
use crate::program::inputs::Inputs;
use crate::routes::EnergyModel;
use crate::taylor::TaylorProgram;
use crate::taylor::series::SeriesOp;
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

/// T = ½ (ṙ² + r² θ̇²), a point in polar coordinates (r, θ) = (q₀, q₁), in `g`.
fn polar_kinetic(g: &mut Graph) -> usize {
    let (r, _, rd, thd) = (g.coord(0), g.coord(1), g.velocity(0), g.velocity(1));
    let half = g.constant(0.5);
    let (rd2, r2, thd2) = (
        g.powi(rd, 2).unwrap(),
        g.powi(r, 2).unwrap(),
        g.powi(thd, 2).unwrap(),
    );
    let rt = g.binary(Binary::Mul, r2, thd2).unwrap();
    let sum = g.binary(Binary::Add, rd2, rt).unwrap();
    g.binary(Binary::Mul, half, sum).unwrap()
}

/// Two masses on springs to the wall, the first driven by F cos ω t (U = ½ k (x₁² + x₂²) −
/// F x₁ cos ω t, M = diag(2, m₂)): ω t is expanded at order 0 alone (sin and cos sum ω
/// above it), M's factor has no entry below the diagonal to solve with, and the series
/// still follow the recursion xₖ₊₂ = (−k xₖ + F cₖ) / (m (k + 1)(k + 2)), with cₖ =
/// ωᵏ cos(ω t₀ + k π/2) / k!, interpreted and unrolled alike, bit for bit.
#[test]
fn unread_orders_and_zeros_of_the_mass_matrix_are_skipped() {
    let mut g = Graph::new();
    let (x1, x2, v1, v2) = (g.coord(0), g.coord(1), g.velocity(0), g.velocity(1));
    let (m2, omega, t) = (g.param(0), g.param(1), g.time());
    let (half, k, force) = (g.constant(0.5), g.constant(3.0), g.constant(0.7));
    let square = |g: &mut Graph, x: usize| g.powi(x, 2).unwrap();
    let (v1s, v2s, x1s, x2s) = (
        square(&mut g, v1),
        square(&mut g, v2),
        square(&mut g, x1),
        square(&mut g, x2),
    );
    let heavy = g.binary(Binary::Mul, m2, v2s).unwrap();
    let two = g.constant(2.0);
    let light = g.binary(Binary::Mul, two, v1s).unwrap();
    let sum = g.binary(Binary::Add, light, heavy).unwrap();
    let kinetic = g.binary(Binary::Mul, half, sum).unwrap();
    let springs = g.binary(Binary::Add, x1s, x2s).unwrap();
    let springs = g.binary(Binary::Mul, k, springs).unwrap();
    let springs = g.binary(Binary::Mul, half, springs).unwrap();
    let phase = g.binary(Binary::Mul, omega, t).unwrap();
    let drive = g.unary(Unary::Cos, phase).unwrap();
    let drive = g.binary(Binary::Mul, drive, x1).unwrap();
    let drive = g.binary(Binary::Mul, force, drive).unwrap();
    let parts = Energies {
        kinetic,
        potential: Some(g.binary(Binary::Sub, springs, drive).unwrap()),
        dissipation: None,
        forces: None,
    };
    let (m2, omega) = (1.7, 1.3);
    let params = [m2, omega];
    let program = Arc::new(setup(&mut g, 2, &parts, &params).0);
    assert_eq!(
        program.recurrences.factor_nonzero,
        Some(vec![true, true, false, true])
    );
    let time = program.recurrences.time.expect("the model reads t");
    let reads_t = |op: &SeriesOp| op.operands().contains(&time);
    assert!(
        program.recurrences.order0.iter().any(reads_t),
        "{:?}",
        program.recurrences.order0
    );
    assert!(
        !program.recurrences.varying.iter().any(reads_t),
        "{:?}",
        program.recurrences.varying
    );
    let (t0, q, v) = (0.3, [0.4, -0.2], [0.1, 0.5]);
    let order = 20;
    let mut e = program.expansion(&params, order);
    e.expand(t0, &q, &v).unwrap();
    let mut factorial = 1.0;
    let mut c = vec![0.0; order + 1];
    for (j, c) in c.iter_mut().enumerate() {
        factorial *= j.max(1) as f64;
        let phase = omega * t0 + j as f64 * std::f64::consts::FRAC_PI_2;
        *c = omega.powi(j as i32) * phase.cos() / factorial;
    }
    let (mut a, mut b) = (vec![q[0], v[0]], vec![q[1], v[1]]);
    for j in 0..order - 1 {
        let d = ((j + 1) * (j + 2)) as f64;
        a.push((-3.0 * a[j] + 0.7 * c[j]) / (2.0 * d));
        b.push(-3.0 * b[j] / (m2 * d));
    }
    for j in 1..=order {
        let (x, y) = (e.q(j), [a[j], b[j]]);
        for i in 0..2 {
            assert!(
                (x[i] - y[i]).abs() <= 1e-14 * y[i].abs().max(1e-300),
                "x{i} order {j}: {} against {}",
                x[i],
                y[i]
            );
        }
    }
    let reference = Arc::new(program.interpreted());
    let mut r = reference.expansion(&params, order);
    r.expand(t0, &q, &v).unwrap();
    // Order by order in compiled code, bit for bit the interpreter's.
    assert_eq!((&r.work.q, &r.work.v), (&e.work.q, &e.work.v));
    assert_eq!(program.unroll(order), cfg!(feature = "jit"));
    let mut u = program.expansion(&params, order);
    r.expand(t0, &q, &v).unwrap();
    u.expand(t0, &q, &v).unwrap();
    for j in 0..=order {
        let pairs = (r.q(j).iter().zip(u.q(j))).chain(r.qd(j).iter().zip(u.qd(j)));
        for (x, y) in pairs {
            assert_eq!(x.to_bits(), y.to_bits(), "order {j}: {x} against {y}");
        }
    }
}

/// Kepler in polar coordinates, U = −μ/r: ∂U/∂r = (μ/r)/r becomes μ/r², r² being M₁₁'s
/// square; against μ r⁻¹ (no quotient at all), the series agree to rounding at every order.
#[test]
fn quotients_of_quotients_are_one_quotient() {
    let kepler = |inverse: bool| {
        let mut g = Graph::new();
        let kinetic = polar_kinetic(&mut g);
        let (r, mu) = (g.coord(0), g.param(0));
        let over = if inverse {
            let inv = g.powi(r, -1).unwrap();
            g.binary(Binary::Mul, mu, inv).unwrap()
        } else {
            g.binary(Binary::Div, mu, r).unwrap()
        };
        let parts = Energies {
            kinetic,
            potential: Some(g.unary(Unary::Neg, over).unwrap()),
            dissipation: None,
            forces: None,
        };
        setup(&mut g, 2, &parts, &[1.3]).0
    };
    let quotients = |p: &TaylorProgram| {
        (p.recurrences.varying.iter())
            .filter(|op| matches!(op, SeriesOp::Div { .. }))
            .count()
    };
    let (folded, reference) = (kepler(false), kepler(true));
    assert_eq!(quotients(&folded), 1, "{:?}", folded.recurrences.varying);
    assert_eq!(
        quotients(&reference),
        0,
        "{:?}",
        reference.recurrences.varying
    );
    let (q, v) = ([0.7, 0.4], [0.2, -1.1]);
    let order = 16;
    // Order by order in compiled code (M₁₁ = r² varies: its sums with q̈ are in the code too),
    // bit for bit the interpreter's.
    let folded = Arc::new(folded);
    let mut native = folded.expansion(&[1.3], order);
    let mut interpreted = Arc::new(folded.interpreted()).expansion(&[1.3], order);
    native.expand(0.0, &q, &v).unwrap();
    interpreted.expand(0.0, &q, &v).unwrap();
    assert!(!folded.is_unrolled(order));
    assert_eq!(folded.is_native(), cfg!(feature = "jit"));
    assert_eq!(
        (&native.work.q, &native.work.v),
        (&interpreted.work.q, &interpreted.work.v)
    );
    drop(native);
    let folded = Arc::into_inner(folded).expect("the expansions dropped");
    let mut e = Arc::new(folded).expansion(&[1.3], order);
    let mut f = Arc::new(reference).expansion(&[1.3], order);
    e.expand(0.0, &q, &v).unwrap();
    f.expand(0.0, &q, &v).unwrap();
    for k in 1..=order {
        for i in 0..2 {
            let (a, b) = (e.q(k)[i], f.q(k)[i]);
            assert!(
                (a - b).abs() <= 1e-13 * b.abs().max(1e-3),
                "q{i} order {k}: {a} {b}"
            );
        }
    }
}

/// Copies and scalings by exactly 1 are read through and dropped, in M too: T = ½ (ṙ² +
/// r² θ̇²), U = sin θ cos θ − μ/r has x² as a product copied into the power's row, sin
/// beside cos, and M₁₁ = r² scaled by ½ · 2. What remains still expands as the dual
/// numbers of the tapes differentiate (q̈ at order 0, against the accelerations).
#[test]
fn copies_and_unit_scalings_are_read_through() {
    let mut g = Graph::new();
    let kinetic = polar_kinetic(&mut g);
    let (r, th, mu) = (g.coord(0), g.coord(1), g.param(0));
    let (s, c) = (
        g.unary(Unary::Sin, th).unwrap(),
        g.unary(Unary::Cos, th).unwrap(),
    );
    let sc = g.binary(Binary::Mul, s, c).unwrap();
    let over = g.binary(Binary::Div, mu, r).unwrap();
    let parts = Energies {
        kinetic,
        potential: Some(g.binary(Binary::Sub, sc, over).unwrap()),
        dissipation: None,
        forces: None,
    };
    let (program, model) = setup(&mut g, 2, &parts, &[1.3]);
    assert!(
        !program
            .recurrences
            .order0
            .iter()
            .any(|op| matches!(op, SeriesOp::Copy { .. })),
        "{:?}",
        program.recurrences.order0
    );
    // M₁₁ is the square r² itself; M₀₀ = ½ · 2 a number.
    let r_row = program.recurrences.coords[0].unwrap();
    let m11 = program.recurrences.mass_full[3];
    assert!(
        program
            .recurrences
            .varying
            .contains(&SeriesOp::Square { out: m11, a: r_row }),
        "{:?}",
        program.recurrences.varying
    );
    assert!(program.recurrences.mass_varying == [false, false, false, true]);
    let program = Arc::new(program);
    let (q, v) = ([0.7, 0.4], [0.2, -1.1]);
    let mut e = program.expansion(&[1.3], 6);
    e.expand(0.0, &q, &v).unwrap();
    let mut qdd = [0.0; 2];
    model.accelerations_into(0.0, &q, &v, &mut qdd).unwrap();
    for i in 0..2 {
        // q̇'s coefficient 1 is q̈₀.
        assert!(
            (e.qd(1)[i] - qdd[i]).abs() < 1e-14 * qdd[i].abs().max(1.0),
            "{i}"
        );
    }
}

/// The expansion of a model over every function — M depending on q, L on t and q̇,
/// damping and forces — summed at a step h agrees with a tight DOP853 run to round-off.
#[test]
fn chirp_forcing_sums_stop_at_the_phase_degree() {
    // ẍ = cos(u(t)) + sinh(0.4 t) with u = 0.8 t² + 0.3 t (T = ½ẋ², Q the forcing): the
    // phases are polynomials in t of degree 2 and 1, so their sums stop there.
    let mut g = Graph::new();
    let (v, t, half) = (g.velocity(0), g.time(), g.constant(0.5));
    let mul = |g: &mut Graph, a: usize, b: usize| g.binary(Binary::Mul, a, b).unwrap();
    let v2 = g.powi(v, 2).unwrap();
    let t2 = g.powi(t, 2).unwrap();
    let (a2, a1, b1) = (g.constant(0.8), g.constant(0.3), g.constant(0.4));
    let (u2, u1) = (mul(&mut g, a2, t2), mul(&mut g, a1, t));
    let u = g.binary(Binary::Add, u2, u1).unwrap();
    let cos_u = g.unary(Unary::Cos, u).unwrap();
    let bt = mul(&mut g, b1, t);
    let sinh_bt = g.unary(Unary::Sinh, bt).unwrap();
    let parts = Energies {
        kinetic: mul(&mut g, half, v2),
        potential: None,
        dissipation: None,
        forces: Some(vec![g.binary(Binary::Add, cos_u, sinh_bt).unwrap()]),
    };
    let (program, _) = setup(&mut g, 1, &parts, &[]);
    let degrees: Vec<_> = program
        .recurrences
        .varying
        .iter()
        .filter_map(|op| match *op {
            SeriesOp::SinCos { degree, .. } => Some(degree),
            _ => None,
        })
        .collect();
    assert_eq!(degrees, [Some(2), Some(1)]);
    // Reference: cos(u(t₀ + h)) = Re(e^(iu₀) e^(iu₁h) e^(iu₂h²)) with u₁ = 0.3 + 1.6 t₀,
    // u₂ = 0.8, a product of two exponential series; sinh(0.4(t₀ + h)) term by term.
    let (t0, order) = (0.7, 22);
    let (u0, u1, u2) = (0.8 * t0 * t0 + 0.3 * t0, 0.3 + 1.6 * t0, 0.8);
    let mul_c = |(a, b): (f64, f64), (c, d): (f64, f64)| (a * c - b * d, a * d + b * c);
    let series = |w: f64, stride: usize| {
        // e^(iwh^stride) = Σₘ (iw)ᵐ h^(m·stride) / m!
        let mut s = vec![(0.0, 0.0); order + 1];
        let mut term = (1.0, 0.0);
        for m in 0..=order / stride {
            s[m * stride] = term;
            term = mul_c(term, (0.0, w / (m + 1) as f64));
        }
        s
    };
    let (e1, e2) = (series(u1, 1), series(u2, 2));
    let (b, mut sinh_k) = (0.4_f64, (0.4 * t0).sinh());
    let (mut sinh_other, mut scale) = ((0.4 * t0).cosh(), 1.0);
    let mut forcing = Vec::new();
    for k in 0..=order {
        let mut p = (0.0, 0.0);
        for j in 0..=k {
            let x = mul_c(e1[j], e2[k - j]);
            p = (p.0 + x.0, p.1 + x.1);
        }
        let cos_k = mul_c((u0.cos(), u0.sin()), p).0;
        forcing.push(cos_k + sinh_k * scale);
        scale *= b / (k + 1) as f64;
        std::mem::swap(&mut sinh_k, &mut sinh_other);
    }
    let program = Arc::new(program);
    let mut e = program.expansion(&[], order);
    e.expand(t0, &[0.2], &[-0.1]).unwrap();
    // xₖ₊₂ = Fₖ / ((k + 1)(k + 2)), to a few roundings (measured: 2e-15 at worst).
    for k in 0..order - 1 {
        let want = forcing[k] / ((k + 1) * (k + 2)) as f64;
        let got = e.q(k + 2)[0];
        assert!(
            (got - want).abs() <= 1e-14 * want.abs(),
            "x_{}: {got} against {want}",
            k + 2
        );
    }
    // The interpreter and the compiled expansion, unrolled, give the same bits.
    let mut interpreted = Arc::new(program.interpreted()).expansion(&[], order);
    interpreted.expand(t0, &[0.2], &[-0.1]).unwrap();
    assert_eq!(
        (&interpreted.work.q, &interpreted.work.v),
        (&e.work.q, &e.work.v)
    );
    #[cfg(feature = "jit")]
    {
        assert!(program.unroll(order));
        let mut native = program.expansion(&[], order);
        native.expand(t0, &[0.2], &[-0.1]).unwrap();
        assert_eq!((&native.work.q, &native.work.v), (&e.work.q, &e.work.v));
    }
}

/// A dropped expansion's work space serves the next one to its order, rebound when the
/// parameters differ: T = ½ m ẋ², U = ½ k x² from (1, 0) has x₂ = −k / 2m, and M = m is
/// factored once per binding (a stale factor would keep the old m).
#[test]
fn spare_work_spaces_are_rebound_to_new_parameters() {
    let mut g = Graph::new();
    let (x, v, half) = (g.coord(0), g.velocity(0), g.constant(0.5));
    let (m, k) = (g.param(0), g.param(1));
    let v2 = g.powi(v, 2).unwrap();
    let x2 = g.powi(x, 2).unwrap();
    let (mv2, kx2) = (
        g.binary(Binary::Mul, m, v2).unwrap(),
        g.binary(Binary::Mul, k, x2).unwrap(),
    );
    let parts = Energies {
        kinetic: g.binary(Binary::Mul, half, mv2).unwrap(),
        potential: Some(g.binary(Binary::Mul, half, kx2).unwrap()),
        dissipation: None,
        forces: None,
    };
    let (program, _) = setup(&mut g, 1, &parts, &[1.0, 1.0]);
    let program = Arc::new(program);
    let spares = |p: &TaylorProgram| p.spares.lock().unwrap().len();
    for (m, k) in [(1.0, 1.0), (4.0, 1.0), (4.0, 9.0), (1.0, 1.0), (4.0, 9.0)] {
        let mut e = program.expansion(&[m, k], 6);
        e.expand(0.0, &[1.0], &[0.0]).unwrap();
        let x2: f64 = -k / (2.0 * m);
        assert!(
            (e.q(2)[0] - x2).abs() < 1e-15,
            "m = {m}, k = {k}: {:?}",
            e.q(2)
        );
        let fresh = {
            let mut e = Arc::new(program.interpreted()).expansion(&[m, k], 6);
            e.expand(0.0, &[1.0], &[0.0]).unwrap();
            (0..=6).map(|j| e.q(j)[0].to_bits()).collect::<Vec<_>>()
        };
        let reused: Vec<_> = (0..=6).map(|j| e.q(j)[0].to_bits()).collect();
        assert_eq!(reused, fresh, "m = {m}, k = {k}");
        assert_eq!(spares(&program), 0, "the spare is in use");
        drop(e);
        assert_eq!(spares(&program), 1, "one work space, back after each run");
    }
    // Two at once: the second is new; both are kept.
    let (a, b) = (
        program.expansion(&[1.0, 1.0], 6),
        program.expansion(&[1.0, 1.0], 6),
    );
    drop((a, b));
    assert_eq!(spares(&program), 2);
}
