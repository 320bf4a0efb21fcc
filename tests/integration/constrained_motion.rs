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
        Method::StormerVerlet,
        Method::Yoshida4,
        Method::BlanesMoan4,
        Method::Midpoint,
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
                assert_eq!(fits, ["rk4", "dopri5", "dop853", "radau5"], "{method}");
            }
            other => panic!("{method}: {other:?}"),
        }
    }
}

#[test]
fn auto_chooses_a_projected_method_and_says_why() {
    let p = pendulum(1.0, 1.0);
    let q0 = [0.6_f64.sin(), -0.6_f64.cos()];
    for options in [Options::fixed(0.01), Options::adaptive(1e-9, 1e-9)] {
        let sol = solve(&p, &q0, &[0.0, 0.0], (0.0, 1.0), Method::Auto, &options).unwrap();
        assert_eq!(sol.stats.method, Method::Dop853);
        let why = sol.stats.choice.unwrap();
        assert!(why.starts_with("constrained (1 rows)"), "{why}");
    }
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
