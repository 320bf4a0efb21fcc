"""The seed's systems with their constraints kept (``lagrangian.scenes.CONSTRAINED``), each
against the seed's closed form: the rolling cylinder's eq. 48 and the friction force rolling
needs, the ball in a sphere's eq. 49–53 small-oscillation frequency (by ``modes`` and by a
simulated period), the rhombus link's Q = P tan θ (example 3) and the spring rhombus's balance
(example 4) with their reactions, and the Cartesian pendulum's period and rod tension."""

import inspect
import math

import numpy as np
import pytest

import lagrangian as lg

scipy_special = pytest.importorskip("scipy.special")

TIGHT = dict(rtol=1e-12, atol=1e-12)


def pendulum_period(omega: float, amplitude: float) -> float:
    """The exact period 4 K(sin(θ₀/2)) / ω of θ̈ + ω² sin θ = 0 from rest at θ₀."""
    return 4.0 * scipy_special.ellipk(math.sin(amplitude / 2) ** 2) / omega


def test_constrained_scenes_are_in_the_namespace():
    assert lg.scenes.CONSTRAINED == (
        "cartesian_pendulum", "rolling_cylinder_constrained", "ball_in_sphere_constrained",
        "rhombus_link_constrained", "spring_rhombus_constrained")
    rust = {s["name"] for s in lg.scenes.catalog()}
    for name in lg.scenes.CONSTRAINED:
        scene = getattr(lg.scenes, name)
        assert name not in rust and name not in lg.scenes.__all__
        assert "seed" in scene.__doc__ and "constraint" in scene.__doc__, name
        model = scene()
        assert isinstance(model, lg.Model) and model.constraint_names, name
        # The parameters are the model's, with the defaults of the Rust scene of that system.
        defaults = {k: p.default for k, p in inspect.signature(scene).parameters.items()}
        assert model.parameters == defaults, name
    for name in ("rolling_cylinder", "ball_in_sphere", "rhombus_link", "spring_rhombus"):
        ours = inspect.signature(getattr(lg.scenes, name + "_constrained")).parameters
        theirs = inspect.signature(getattr(lg.scenes, name)).parameters
        assert {k: p.default for k, p in ours.items()} == {
            k: p.default for k, p in theirs.items()}, name


# -- the Cartesian pendulum ---------------------------------------------------------------------


def test_cartesian_pendulum_period_and_tension():
    m, l, g, th0 = 1.3, 0.8, 9.81, 1.2
    model = lg.scenes.cartesian_pendulum(m=m, l=l, g=g)
    q0 = [l * math.sin(th0), -l * math.cos(th0)]
    period = pendulum_period(math.sqrt(g / l), th0)
    sol = model.simulate(q0, [0.0, 0.0], period, t_eval=[period / 2, period], **TIGHT)
    # Half a period: the mirror image; a whole one: back at the start.
    assert np.allclose(sol.q[0], [-q0[0], q0[1]], atol=1e-9)
    assert np.allclose(sol.q[1], q0, atol=1e-9) and np.allclose(sol.qd[1], 0.0, atol=1e-8)
    assert sol.stats["constraint_residual"] < 1e-10
    # The rod's tension −2lλ = m (g cos θ + l θ̇²), along the run.
    dense = model.simulate(q0, [0.0, 0.0], period, t_eval=np.linspace(0, period, 41), **TIGHT)
    theta = np.arctan2(dense.q[:, 0], -dense.q[:, 1])
    rate = (dense.q[:, 0] * dense.qd[:, 1] - dense.q[:, 1] * dense.qd[:, 0]) / l**2
    tension = -2 * l * dense.multipliers[:, 0]
    assert np.allclose(tension, m * (g * np.cos(theta) + l * rate**2), rtol=1e-9)
    # Small swings: ω² = g / l on the constraint manifold.
    assert np.allclose(model.modes([0.0, -l]).omega_squared, [g / l], rtol=1e-12)


# -- the rolling cylinder, seed eq. 45–48 ---------------------------------------------------------


def test_rolling_cylinder_acceleration_and_friction():
    m, j, r, g, alpha = 2.0, 0.015, 0.12, 9.81, 0.4
    model = lg.scenes.rolling_cylinder_constrained(m=m, j=j, r=r, g=g, alpha=alpha)
    accel = m * g * math.sin(alpha) / (m + j / r**2)  # eq. 48
    friction = -(j / r**2) * accel  # along +x: up the slope
    v0, t_end = 0.5, 2.0
    times = np.linspace(0.0, t_end, 9)
    sol = model.simulate([0.0, 0.0], [v0, v0 / r], t_end, t_eval=times, **TIGHT)
    x = v0 * times + 0.5 * accel * times**2
    assert np.allclose(sol.q[:, 0], x, rtol=1e-11, atol=1e-12)
    assert np.allclose(sol.q[:, 1], x / r, rtol=1e-11, atol=1e-11)  # x = rθ, eq. 45
    assert np.allclose(sol.multipliers[:, 0], friction, rtol=1e-10)
    assert np.allclose(sol.constraint_forces, np.outer(np.ones_like(times), [friction,
                                                                            -r * friction]),
                       rtol=1e-10)
    # The same from the state alone, and it is the friction the cylinder's spin needs.
    lam = model.multipliers(0.0, [0.3, 0.3 / r], [1.0, 1.0 / r])
    assert lam[0] == pytest.approx(friction, rel=1e-13)
    assert -r * lam[0] == pytest.approx(j * accel / r, rel=1e-13)  # J θ̈ = torque
    # Rolling needs a friction coefficient of at least |λ| / N with N = m g cos α.
    needed = abs(lam[0]) / (m * g * math.cos(alpha))
    assert needed == pytest.approx(math.tan(alpha) * (j / r**2) / (m + j / r**2), rel=1e-13)
    assert sol.stats["constraint_residual"] < 1e-10
    # And it matches the seed's eliminated scene step for step.
    reduced = lg.scenes.rolling_cylinder(m=m, j=j, r=r, g=g, alpha=alpha)
    ref = reduced.simulate([0.0], [v0], t_end, t_eval=times, **TIGHT)
    assert np.allclose(sol.q[:, 0], ref.q[:, 0], rtol=1e-11, atol=1e-12)


def test_rolling_cylinder_project_restores_rolling():
    model = lg.scenes.rolling_cylinder_constrained()
    q, qd = model.project([0.2, 1.0], [0.4, 0.0])
    r = model.parameters["r"]
    assert q[0] == pytest.approx(r * q[1], abs=1e-14)
    assert qd[0] == pytest.approx(r * qd[1], abs=1e-14)


# -- the ball in a sphere, seed eq. 49–53 ----------------------------------------------------------


def test_ball_in_sphere_frequency_by_modes_and_period():
    m, j, r1, r2, g = 1.0, 0.016, 1.0, 0.2, 9.81
    model = lg.scenes.ball_in_sphere_constrained(m=m, j=j, r1=r1, r2=r2, g=g)
    omega2 = g / ((r1 - r2) * (1 + j / (m * r2**2)))  # eq. 53 linearized
    modes = model.modes([0.0, 0.0])
    assert np.allclose(modes.omega_squared, [omega2], rtol=1e-12)
    # A simulated swing returns after the exact period of eq. 53 (a pendulum of frequency ω).
    th0 = 0.3
    period = pendulum_period(math.sqrt(omega2), th0)
    q0 = [th0, (r1 - r2) * th0 / r2]
    sol = model.simulate(q0, [0.0, 0.0], period, t_eval=[period / 2, period], **TIGHT)
    assert sol.q[0, 0] == pytest.approx(-th0, abs=1e-9)
    assert np.allclose(sol.q[1], q0, atol=1e-9) and np.allclose(sol.qd[1], 0.0, atol=1e-8)
    # Eq. 49 holds along the run: (r1 − r2) θ1 = r2 θ2.
    assert sol.stats["constraint_residual"] < 1e-10
    # The multiplier is the friction force along the path: λ = −(J/r2²) s̈.
    th, w = 0.25, 0.7
    lam = model.multipliers(0.0, [th, (r1 - r2) * th / r2], [w, (r1 - r2) * w / r2])[0]
    s_ddot = (r1 - r2) * (-omega2 * math.sin(th))
    assert lam == pytest.approx(-(j / r2**2) * s_ddot, rel=1e-12)


# -- the rhombus link, seed §3.2 example 3 ----------------------------------------------------------


@pytest.mark.parametrize("q_load", [0.4, 3.0, 11.0])
def test_rhombus_link_q_equals_p_tan_theta(q_load):
    l, p = 0.7, 3.0
    model = lg.scenes.rhombus_link_constrained(l=l, p=p, q=q_load)
    eq = model.equilibrium([0.5, 0.2])
    theta = math.atan2(eq.q[1], eq.q[0])
    assert q_load == pytest.approx(p * math.tan(theta), rel=1e-12)
    assert eq.multipliers[0] == pytest.approx(-math.hypot(p, q_load) / l, rel=1e-12)
    assert np.allclose(eq.constraint_forces, [-2 * p, -2 * q_load], rtol=1e-12)
    assert eq.stability == "stable"
    # The seed's own angle: the Rust scene in θ balances at the same place.
    reduced = lg.scenes.rhombus_link(l=l, p=p, q=q_load).equilibrium([0.5])
    assert math.tan(reduced.q[0]) == pytest.approx(math.tan(theta), rel=1e-9)


# -- the spring rhombus, seed §3.2 example 4 ---------------------------------------------------------


def spring_rhombus_angle(a, k, l0, m, g):
    """The root of m g sin θ = 2k(L0 − a sin θ) cos θ on (0, asin(min(L0/a, 1))), by
    bisection (bounded: 200 halvings)."""
    f = lambda th: m * g * math.sin(th) - 2 * k * (l0 - a * math.sin(th)) * math.cos(th)
    lo, hi = 0.0, math.asin(min(l0 / a, 1.0))
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f(mid) < 0 else (lo, mid)
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("a, l0, k, m", [(0.7, 0.5, 300.0, 3.0), (1.0, 0.8, 50.0, 2.0),
                                         (2.0, 0.3, 400.0, 0.7)])
def test_spring_rhombus_balance(a, l0, k, m):
    g = 9.81
    model = lg.scenes.spring_rhombus_constrained(a=a, k=k, l0=l0, m=m, g=g)
    eq = model.equilibrium([0.5 * a, 0.8 * a])
    theta = spring_rhombus_angle(a, k, l0, m, g)
    assert math.atan2(eq.q[0], eq.q[1]) == pytest.approx(theta, abs=1e-12)
    assert eq.multipliers[0] == pytest.approx(-m * g / (a * math.cos(theta)), rel=1e-10)
    # The reaction balances the spring and the weight: Gᵀλ = ∇U.
    x, y = eq.q
    grad = [-4 * k * (l0 - x), -2 * m * g]
    assert np.allclose(eq.constraint_forces, grad, rtol=1e-10, atol=1e-10)
    assert eq.stability == "stable"


# -- bad input --------------------------------------------------------------------------------------


@pytest.mark.parametrize("call, match", [
    (lambda: lg.scenes.cartesian_pendulum(l=0.0), "'l' = 0.0 must be > 0"),
    (lambda: lg.scenes.cartesian_pendulum(g=math.nan), "not finite"),
    (lambda: lg.scenes.rolling_cylinder_constrained(r=-0.1), "'r' = -0.1 must be > 0"),
    (lambda: lg.scenes.ball_in_sphere_constrained(r1=0.2, r2=0.2), "r2 = 0.2 must be less"),
    (lambda: lg.scenes.spring_rhombus_constrained(k=math.inf), "not finite"),
    (lambda: lg.scenes.rhombus_link_constrained(l=-1.0), "'l' = -1.0 must be > 0"),
])
def test_bad_parameters_are_value_errors(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_non_numbers_are_type_errors():
    with pytest.raises(TypeError, match="'m' must be a real number"):
        lg.scenes.cartesian_pendulum(m="1")
    with pytest.raises(TypeError):
        lg.scenes.rolling_cylinder_constrained(mass=1.0)


# -- examples/seed.py -------------------------------------------------------------------------------


def test_seed_example_constrained_section_meets_the_closed_forms():
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).resolve().parents[2] / "examples" / "seed.py"
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    constrained, identified = done.stdout.split("Constrained:", 1)[1].split(
        "Parameters from measurements", 1)
    rows = [line for line in constrained.splitlines()[3:] if line.strip()]
    assert len(rows) == 8, rows
    for line in rows:
        # The error column follows the 34 + 1 + 34 characters of the two text columns.
        error = float(line[70:79])
        assert error < 1e-9, line
    # The last section: k and c identified within four of their reported standard errors.
    fitted = [line.split() for line in identified.splitlines() if " ± " in line]
    assert [f[0] for f in fitted] == ["k", "c"], identified
    for name, _, value, _, sigma, *_ in fitted:
        truth = {"k": 25.0, "c": 0.8}[name]
        assert abs(float(value) - truth) < 4 * float(sigma), identified
