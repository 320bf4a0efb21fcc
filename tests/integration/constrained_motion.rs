//! Constrained systems in motion (issue 41 item 3): the Runge–Kutta methods and radau5 on
//! Lagrange's equations of the first kind, each accepted step projected back onto the
//! constraints; against closed forms, with the residual held at every output.

use super::constraints::{Diagonal, Linear, PushX, Row, Rows, VRow, holonomic, point};
use lagrangian::integrators::{Event, Method, Options, Solution, solve};
use lagrangian::scenes::elliptic_k;
use lagrangian::{Constrained, Constraints, Dynamics, Error, System};

const G: f64 = 9.81;

fn pendulum(m: f64, l: f64) -> Constrained<System<Diagonal, Linear>, Rows> {
    Constrained::new(point(m, true), holonomic(&[Row::Circle(l)]))
}

/// The largest |g| and |ġ| over every output state of `sol`.
fn worst_residual<C: Constraints>(
    system: &Constrained<System<Diagonal, Linear>, C>,
    sol: &Solution,
) -> f64 {
    (0..sol.len())
        .map(|i| {
            system
                .residuals(sol.t[i], sol.q_at(i), sol.qd_at(i))
                .unwrap()
                .max_abs()
        })
        .fold(0.0, f64::max)
}

#[test]
fn cartesian_pendulum_period_by_the_elliptic_integral_every_projected_method() {
    // Released from rest at θ₀ = 2 rad: after one period T = 4 √(l/g) K(sin(θ₀/2)) it is back.
    let (m, l, th0) = (0.9, 1.3, 2.0_f64);
    let p = pendulum(m, l);
    let period = 4.0 * (l / G).sqrt() * elliptic_k((th0 / 2.0).sin()).unwrap();
    let q0 = [l * th0.sin(), -l * th0.cos()];
    let e0 = p.energy(0.0, &q0, &[0.0, 0.0]).unwrap();
    for (method, options, tol) in [
        (Method::Dop853, Options::adaptive(1e-12, 1e-12), 1e-9),
        (Method::Dopri5, Options::adaptive(1e-10, 1e-12), 1e-7),
        (Method::Radau5, Options::adaptive(1e-10, 1e-12), 1e-6),
        (Method::Rk4, Options::fixed(period / 4000.0), 1e-9),
    ] {
        let sol = solve(&p, &q0, &[0.0, 0.0], (0.0, period), method, &options).unwrap();
        let (_, q, qd) = sol.last().unwrap();
        for i in 0..2 {
            assert!((q[i] - q0[i]).abs() < tol, "{method}: {q:?} against {q0:?}");
            assert!(qd[i].abs() < 10.0 * tol / period, "{method}: {qd:?}");
        }
        // On the circle at every output, to the run's tolerance relative to |q| ≤ l and
        // |q̇| ≤ v_max (g has gradient of size ≤ 2l: |g| ≤ 2 tol l², |ġ| ≤ 2 tol l v_max).
        let rtol = options
            .dt
            .map_or(options.rtol, |_| lagrangian::PROJECTION_TOLERANCE);
        let v_max = (2.0 * G * l * (1.0 - th0.cos())).sqrt();
        let bound = 2.0 * rtol * l * (l + v_max);
        let worst = worst_residual(&p, &sol);
        assert!(worst <= bound, "{method}: residual {worst:e} > {bound:e}");
        assert!(sol.stats.constraint_residual <= bound);
        assert!(sol.stats.projections > 0, "{method}: no step was projected");
        for i in 0..sol.len() {
            let e = p.energy(sol.t[i], sol.q_at(i), sol.qd_at(i)).unwrap();
            assert!(
                (e - e0).abs() < 100.0 * tol * e0.abs(),
                "{method}: energy {e} vs {e0}"
            );
        }
    }
}

#[test]
fn rk4_long_run_stays_on_the_circle() {
    // 2·10⁵ fixed steps (≈ 480 periods): without projection RK4 drifts off the circle by its
    // local error every step; with it |g| stays at round-off.
    let (m, l) = (1.0, 1.0);
    let p = pendulum(m, l);
    let q0 = [1.0_f64.sin(), -1.0_f64.cos()];
    let options = Options::fixed(5e-3).with_output(lagrangian::Output::Every(1000));
    let sol = solve(&p, &q0, &[0.0, 0.0], (0.0, 1000.0), Method::Rk4, &options).unwrap();
    assert_eq!(sol.stats.accepted_steps, 200_000);
    assert!(
        sol.stats.constraint_residual < 1e-11,
        "{:e}",
        sol.stats.constraint_residual
    );
    assert!(worst_residual(&p, &sol) < 1e-11);
}

#[test]
fn rolling_cylinder_rolls_down_with_the_seed_acceleration() {
    // Seed eq. 48: ẍ = g sin α / (1 + J/(m r²)); from rest, x = ½ ẍ t².
    let (m, r, alpha) = (2.0, 0.3, 0.4_f64);
    let j = 0.5 * m * r * r;
    let cylinder = System::new(2, Diagonal(vec![m, j]))
        .with_potential(Linear(vec![-m * G * alpha.sin(), 0.0]));
    let rolling = Constrained::new(cylinder, holonomic(&[Row::Rolling(r)]));
    let a = G * alpha.sin() / (1.0 + j / (m * r * r));
    for method in [Method::Dop853, Method::Radau5] {
        let sol = solve(
            &rolling,
            &[0.0, 0.0],
            &[0.0, 0.0],
            (0.0, 2.0),
            method,
            &Options::adaptive(1e-12, 1e-12),
        )
        .unwrap();
        let (_, q, qd) = sol.last().unwrap();
        assert!((q[0] - 2.0 * a).abs() < 1e-10, "{method}: {q:?}");
        assert!((q[1] - 2.0 * a / r).abs() < 1e-9);
        assert!((qd[0] - 2.0 * a).abs() < 1e-10);
    }
}

#[test]
fn knife_edge_runs_on_its_circle() {
    // No force, speed v and turning rate ω: a circle of radius v/ω through the origin,
    // x = (v/ω) sin ωt, y = (v/ω)(1 − cos ωt) — a path no choice of coordinates gives, since
    // the knife-edge row sin φ ẋ − cos φ ẏ = 0 is not integrable.
    let (m, inertia, v, w) = (1.3, 0.2, 1.5, 0.8);
    let knife = Constrained::new(
        System::new(3, Diagonal(vec![m, m, inertia])).with_forces(PushX(0.0)),
        Rows {
            holonomic: Vec::new(),
            velocity: vec![VRow::Knife],
        },
    );
    let t = 7.0;
    for method in [Method::Dop853, Method::Radau5, Method::Dopri5] {
        let sol = solve(
            &knife,
            &[0.0, 0.0, 0.0],
            &[v, 0.0, w],
            (0.0, t),
            method,
            &Options::adaptive(1e-11, 1e-12),
        )
        .unwrap();
        let (_, q, qd) = sol.last().unwrap();
        let radius = v / w;
        let tol = if method == Method::Dopri5 { 1e-7 } else { 1e-8 };
        assert!(
            (q[0] - radius * (w * t).sin()).abs() < tol,
            "{method}: {q:?}"
        );
        assert!(
            (q[1] - radius * (1.0 - (w * t).cos())).abs() < tol,
            "{method}: {q:?}"
        );
        assert!((q[2] - w * t).abs() < tol);
        assert!((qd[0].hypot(qd[1]) - v).abs() < tol);
    }
}

#[test]
fn bead_on_a_rotating_wire_moves_out_by_cosh() {
    // A massless wire through the origin turning at ω (a moving constraint): r̈ = ω² r, so from
    // rest on the wire r = r₀ cosh ωt.
    let (m, w, r0) = (0.5, 1.2, 0.3);
    let bead = Constrained::new(point(m, false), holonomic(&[Row::Wire(w)]));
    let t = 1.5;
    for method in [Method::Dop853, Method::Radau5] {
        // At t = 0 the wire lies along x; the bead turns with it: q̇ = (0, ω r₀).
        let sol = solve(
            &bead,
            &[r0, 0.0],
            &[0.0, w * r0],
            (0.0, t),
            method,
            &Options::adaptive(1e-11, 1e-12),
        )
        .unwrap();
        let (_, q, _) = sol.last().unwrap();
        let r = r0 * (w * t).cosh();
        assert!((q[0].hypot(q[1]) - r).abs() < 1e-8, "{method}: {q:?}");
        assert!((q[1].atan2(q[0]) - w * t).abs() < 1e-8);
        assert!(sol.stats.constraint_residual < 1e-10);
    }
    // The wire does work: h = ½ m (ṙ² + ω² r²) = ½ m r₀² ω² cosh 2ωt, so the reactions' power
    // is dh/dt = m r₀² ω³ sinh 2ωt, exactly what Gᵀλ·q̇ gives on the closed-form state.
    for t in [0.0, 0.4, 1.1] {
        let (r, rd) = (r0 * (w * t).cosh(), r0 * w * (w * t).sinh());
        let (s, c) = (w * t).sin_cos();
        let q = [r * c, r * s];
        let qd = [rd * c - r * w * s, rd * s + r * w * c];
        let h = bead.energy(t, &q, &qd).unwrap();
        let want_h = 0.5 * m * r0 * r0 * w * w * (2.0 * w * t).cosh();
        assert!((h - want_h).abs() < 1e-14 * want_h, "{h} {want_h}");
        let power = bead.constraint_power(t, &q, &qd).unwrap();
        let want = m * r0 * r0 * w.powi(3) * (2.0 * w * t).sinh();
        assert!(
            (power - want).abs() < 1e-13 * (1.0 + want.abs()),
            "{power} {want}"
        );
    }
}

#[test]
fn an_event_on_a_constrained_model_finds_the_quarter_period() {
    let (m, l, th0) = (1.0, 0.7, 1.0_f64);
    let p = pendulum(m, l);
    let quarter = (l / G).sqrt() * elliptic_k((th0 / 2.0).sin()).unwrap();
    let options = Options::adaptive(1e-12, 1e-12)
        .with_event(Event::new("x = 0", |_t, q, _qd| q[0]).terminal(1));
    let q0 = [l * th0.sin(), -l * th0.cos()];
    let sol = solve(&p, &q0, &[0.0, 0.0], (0.0, 10.0), Method::Dop853, &options).unwrap();
    let (t, q, _) = sol.last().unwrap();
    assert!((t - quarter).abs() < 1e-9, "{t} against {quarter}");
    assert!((q[1] + l).abs() < 1e-9);
}

#[test]
fn methods_that_do_not_hold_constraints_refuse_them() {
    let p = pendulum(1.0, 1.0);
    let q0 = [0.0, -1.0];
    for method in [
        Method::BlanesMoan4,
        Method::Gauss4,
        Method::Gauss6,
        Method::Taylor,
    ] {
        let options = if method == Method::Taylor {
            Options::adaptive(1e-9, 1e-9)
        } else {
            Options::fixed(0.01)
        };
        match solve(&p, &q0, &[0.5, 0.0], (0.0, 1.0), method, &options) {
            Err(Error::UnsupportedMethod { why, fits, .. }) => {
                assert!(why.contains("constrain"), "{method}: {why}");
                assert_eq!(
                    fits,
                    [
                        "rk4",
                        "dopri5",
                        "dop853",
                        "stormer_verlet",
                        "yoshida4",
                        "yoshida6",
                        "yoshida8",
                        "midpoint",
                        "radau5"
                    ],
                    "{method}"
                );
            }
            other => panic!("{method}: {other:?}"),
        }
    }
}

/// Holonomic rows that do not read t, declared so (the trait's default is a moving set).
pub(crate) struct Still(pub(crate) Rows);
impl Constraints for Still {
    fn holonomic_count(&self) -> usize {
        self.0.holonomic_count()
    }
    fn holonomic<D: lagrangian::Scalar>(&self, t: D, q: &[D], out: &mut [D]) {
        self.0.holonomic(t, q, out)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

#[test]
fn auto_chooses_a_projected_method_and_says_why() {
    let p = Constrained::new(point(1.0, true), Still(holonomic(&[Row::Circle(1.0)])));
    let q0 = [0.6_f64.sin(), -0.6_f64.cos()];
    // Conservative, separable, holonomic, with a fixed dt: RATTLE (yoshida4); with
    // tolerances only, DOP853 with its steps projected.
    for (options, method, reason) in [
        (Options::fixed(0.01), Method::Yoshida4, "RATTLE"),
        (Options::adaptive(1e-9, 1e-9), Method::Dop853, "projected"),
    ] {
        let sol = solve(&p, &q0, &[0.0, 0.0], (0.0, 1.0), Method::Auto, &options).unwrap();
        assert_eq!(sol.stats.method, method);
        let why = sol.stats.choice.unwrap();
        assert!(why.starts_with("constrained (1 "), "{why}");
        assert!(why.contains(reason), "{why}");
        if method == Method::Yoshida4 {
            assert!(sol.stats.constraint_residual < 1e-13);
        }
    }
    // A velocity row keeps the projected methods at a fixed dt too.
    let knife = Constrained::new(
        System::new(3, Diagonal(vec![1.0, 1.0, 0.2])),
        Rows {
            holonomic: Vec::new(),
            velocity: vec![VRow::Knife],
        },
    );
    let fixed = Options::fixed(0.01);
    let sol = solve(
        &knife,
        &[0.0; 3],
        &[1.0, 0.0, 0.5],
        (0.0, 1.0),
        Method::Auto,
        &fixed,
    )
    .unwrap();
    assert_eq!(sol.stats.method, Method::Dop853);
    assert!(
        sol.stats
            .choice
            .unwrap()
            .starts_with("constrained (1 rows)")
    );
}

#[test]
fn an_inconsistent_initial_state_is_refused_before_any_step() {
    let p = pendulum(1.0, 1.0);
    let off = solve(
        &p,
        &[0.0, -1.01],
        &[0.0, 0.0],
        (0.0, 1.0),
        Method::Dop853,
        &Options::adaptive(1e-9, 1e-9),
    );
    match off {
        Err(Error::InconsistentState {
            level, residual, ..
        }) => {
            assert_eq!(level, "position");
            assert!((residual - (1.01_f64.powi(2) - 1.0)).abs() < 1e-14);
        }
        other => panic!("{other:?}"),
    }
    // Velocity off the tangent.
    let off = solve(
        &p,
        &[0.0, -1.0],
        &[0.0, 0.1],
        (0.0, 1.0),
        Method::Radau5,
        &Options::adaptive(1e-9, 1e-9),
    );
    assert!(
        matches!(
            off,
            Err(Error::InconsistentState {
                level: "velocity",
                ..
            })
        ),
        "{off:?}"
    );
    // The projected state runs.
    let (q, qd) = p.project(0.0, &[0.0, -1.01], &[0.0, 0.1], None).unwrap();
    solve(
        &p,
        &q,
        &qd,
        (0.0, 1.0),
        Method::Dop853,
        &Options::adaptive(1e-9, 1e-9),
    )
    .unwrap();
}

/// θ₁ − θ₂ = 0: the double pendulum's two rods locked in line.
struct Locked;
impl Constraints for Locked {
    fn holonomic_count(&self) -> usize {
        1
    }
    fn holonomic<D: lagrangian::Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        out[0] = q[0] - q[1];
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

#[test]
fn a_model_with_a_derived_program_takes_m_and_f_from_one_compiled_run() {
    // The double pendulum stated as expressions, its rods locked in line: a physical pendulum
    // with θ̈ = −g (m₁l₁ + m₂(l₁+l₂)) sin θ / (m₁l₁² + m₂(l₁+l₂)²). The constrained q̈ from the
    // compiled eq. 55 program's M and f (M factored once) equals the closed form and the
    // dual-number route of the same tapes without the program.
    use lagrangian::tape::{EnergyModel, EomProgram, Function, Graph, Inputs, Tape, models};
    use std::sync::Arc;
    let params = [1.3, 0.7, 0.9, 1.1, G];
    let [m1, m2, l1, l2, g] = params;
    let mut graph = Graph::new();
    let parts = models::double_pendulum(&mut graph).unwrap();
    let program = EomProgram::new(&mut graph, 2, params.len(), &parts).unwrap();
    let f = |node: usize, inputs: Inputs| {
        Function::new(
            Arc::new(Tape::new(&graph, &[node], inputs, "part").unwrap()),
            &params,
        )
        .unwrap()
    };
    let plain = EnergyModel::new(
        2,
        f(parts.kinetic, Inputs::kinetic(2, 5)),
        Some(f(parts.potential.unwrap(), Inputs::potential(2, 5))),
        None,
        None,
    )
    .unwrap();
    let derived = plain
        .clone()
        .with_program(program.bind(&params).unwrap())
        .unwrap();
    assert!(derived.derived_program().is_some());
    let (with_program, without) = (
        Constrained::new(derived, Locked),
        Constrained::new(plain, Locked),
    );
    let (moment, inertia) = (
        m1 * l1 + m2 * (l1 + l2),
        m1 * l1 * l1 + m2 * (l1 + l2) * (l1 + l2),
    );
    for (th, w) in [(0.3, 0.0), (-1.2, 2.5), (2.9, -0.4)] {
        let (q, qd) = ([th, th], [w, w]);
        let a = with_program.evaluate(0.0, &q, &qd).unwrap();
        let b = without.evaluate(0.0, &q, &qd).unwrap();
        let want = -g * moment * th.sin() / inertia;
        for i in 0..2 {
            assert!((a.accelerations[i] - want).abs() < 1e-13 * (1.0 + want.abs()));
            assert!((a.accelerations[i] - b.accelerations[i]).abs() < 1e-13);
            assert!((a.reaction_forces[i] - b.reaction_forces[i]).abs() < 1e-12);
        }
        // Through the Dynamics face too (what the integrators call).
        let via = with_program.accelerations(0.0, &q, &qd).unwrap();
        assert!((via[0] - want).abs() < 1e-13 * (1.0 + want.abs()));
    }
    // And in motion: the locked pendulum's period against the compound pendulum's.
    let th0 = 0.8_f64;
    let period = 4.0 * (inertia / (g * moment)).sqrt() * elliptic_k((th0 / 2.0).sin()).unwrap();
    let sol = solve(
        &with_program,
        &[th0, th0],
        &[0.0, 0.0],
        (0.0, period),
        Method::Dop853,
        &Options::adaptive(1e-12, 1e-12),
    )
    .unwrap();
    let (_, q, _) = sol.last().unwrap();
    assert!(
        (q[0] - th0).abs() < 1e-9 && (q[1] - th0).abs() < 1e-9,
        "{q:?}"
    );
}

#[test]
fn the_compiled_constraint_rows_equal_the_dual_number_passes() {
    // The rows of the AD checks in constraints.rs, stated on a graph: G and γ derived there and
    // compiled (ConstraintProgram) against Constrained's dual-number passes on the Rust rows.
    use lagrangian::tape::{Binary, ConstraintProgram, Graph, Unary};
    let mut g = Graph::new();
    let (t, x, y, vx, vy) = (
        g.time(),
        g.coord(0),
        g.coord(1),
        g.velocity(0),
        g.velocity(1),
    );
    let bin = |g: &mut Graph, f, a, b| g.binary(f, a, b).unwrap();
    // q₀² q₁ + sin(q₀ q₁ t)
    let xx = bin(&mut g, Binary::Mul, x, x);
    let xxy = bin(&mut g, Binary::Mul, xx, y);
    let xy = bin(&mut g, Binary::Mul, x, y);
    let xyt = bin(&mut g, Binary::Mul, xy, t);
    let s = g.unary(Unary::Sin, xyt).unwrap();
    let mixed = bin(&mut g, Binary::Add, xxy, s);
    // cos(t) ẋ + x ẏ + t x
    let c = g.unary(Unary::Cos, t).unwrap();
    let a = bin(&mut g, Binary::Mul, c, vx);
    let b = bin(&mut g, Binary::Mul, x, vy);
    let d = bin(&mut g, Binary::Mul, t, x);
    let ab = bin(&mut g, Binary::Add, a, b);
    let vmixed = bin(&mut g, Binary::Add, ab, d);
    let program = ConstraintProgram::new(&mut g, 2, 0, &[mixed], &[vmixed], true).unwrap();
    let rows = program.bind(&[]).unwrap();
    let rust = Constrained::new(
        point(1.0, false),
        Rows {
            holonomic: vec![Row::Mixed],
            velocity: vec![VRow::Mixed],
        },
    );
    for (t, q, qd) in [
        (0.3, [0.7, -1.1], [0.4, 0.9]),
        (1.7, [-0.2, 0.5], [-1.3, 0.2]),
    ] {
        let (mut gc, mut gammac) = ([0.0; 4], [0.0; 2]);
        rows.eval(t, &q, &qd, &mut gc, &mut gammac);
        let gd = rust.constraint_jacobian(t, &q, &qd).unwrap();
        let gammad = rust.gamma(t, &q, &qd).unwrap();
        for i in 0..2 {
            for j in 0..2 {
                assert!((gc[i * 2 + j] - gd[(i, j)]).abs() < 1e-14, "{gc:?} {gd}");
            }
            assert!((gammac[i] - gammad[i]).abs() < 1e-13, "{gammac:?} {gammad}");
        }
    }
    assert_eq!(program.rows(), 2);
    #[cfg(feature = "jit")]
    assert_eq!(program.backend(), "native");
}
