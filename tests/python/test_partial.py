"""A run that fails keeps what it computed: the typed error carries the partial solution
(``err.solution``) and the last accepted state (``err.t``, ``err.q``, ``err.qd``); and
``sol.y`` is SciPy's layout of the states."""

import math

import numpy as np
import pytest

import lagrangian as lg

X0 = 1.0
T_STAR = math.sqrt(6.0 / X0)  # blow-up time of ẍ = x² from the energy-0 start below


def exact(t):
    """x = x₀ / (1 − √(x₀/6) t)² and ẋ, with ẋ₀ = √(2/3) x₀^{3/2} (energy 0)."""
    a = math.sqrt(X0 / 6.0)
    s = 1.0 - a * np.asarray(t)
    return X0 / s**2, 2.0 * X0 * a / s**3


@pytest.fixture
def blow_up():
    x, = lg.coordinates("x")
    return lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=-(x**3) / 3)


def start():
    return [X0], [math.sqrt(2.0 / 3.0) * X0**1.5]


def test_adaptive_failure_carries_the_trajectory_up_to_the_blow_up(blow_up):
    q0, qd0 = start()
    with pytest.raises(lg.StepSizeError, match="radau5") as e:
        blow_up.simulate(q0, qd0, 5.0, method="dop853", rtol=1e-12, atol=1e-12)
    err = e.value
    sol = err.solution
    assert isinstance(sol, lg.Solution)
    # It ends at the blow-up (up to round-off: x ~ 1e26 there).
    assert abs(sol.t[-1] - T_STAR) < 1e-12 and sol.q[-1, 0] > 1e20
    assert len(sol) == 1 + sol.stats["accepted_steps"] and sol.stats["method"] == "dop853"
    x, v = sol.q[:, 0], sol.qd[:, 0]
    # Where x(t) is well conditioned, the state to 1e-6 relative.
    ok = x <= 1e8
    assert ok.sum() > 50
    xe, ve = exact(sol.t[ok])
    assert np.max(np.abs(x[ok] / xe - 1)) < 1e-6
    assert np.max(np.abs(v[ok] / ve - 1)) < 1e-6
    # Up to the end, each point lies on the exact curve: t(x) = (1 − √(x₀/x)) t* is its time.
    assert np.max(np.abs((1 - np.sqrt(X0 / x)) * T_STAR - sol.t)) < 1e-9
    # Energy 0 along the way (relative to the kinetic energy, where x is moderate).
    assert np.max(np.abs(sol.energy[ok]) / (0.5 * v[ok] ** 2)) < 1e-6
    # The last accepted state, as attributes.
    assert err.t == sol.t[-1]
    np.testing.assert_array_equal(err.q, sol.q[-1])
    np.testing.assert_array_equal(err.qd, sol.qd[-1])
    assert f"at t = {err.t}" in str(err)


def test_fixed_step_failure_carries_the_trajectory(blow_up):
    q0, qd0 = start()
    dt = 1e-3
    with pytest.raises(lg.LagrangianError) as e:
        blow_up.simulate(q0, qd0, 5.0, method="rk4", dt=dt)
    err = e.value
    sol = err.solution
    assert len(sol) == 1 + sol.stats["accepted_steps"] > 2000
    np.testing.assert_allclose(sol.t, dt * np.arange(len(sol)), rtol=0, atol=1e-12)
    assert np.all(np.isfinite(sol.q)) and np.all(np.isfinite(sol.qd))
    # RK4's own solution overflows a few steps after t*.
    assert abs(sol.t[-1] - T_STAR) < 0.01
    early = sol.t <= 2.0
    xe, ve = exact(sol.t[early])
    assert np.max(np.abs(sol.q[early, 0] / xe - 1)) < 1e-6
    assert np.max(np.abs(sol.qd[early, 0] / ve - 1)) < 1e-6
    assert err.t == sol.t[-1]
    np.testing.assert_array_equal(err.q, sol.q[-1])


def test_too_many_steps_carries_every_step_taken(blow_up):
    q0, qd0 = start()
    with pytest.raises(lg.TooManyStepsError) as e:
        blow_up.simulate(q0, qd0, 2.0, method="dop853", rtol=1e-12, atol=1e-12, max_steps=40)
    sol = e.value.solution
    stats = sol.stats
    assert stats["accepted_steps"] + stats["rejected_steps"] == 40
    assert len(sol) == 1 + stats["accepted_steps"]
    xe, _ = exact(sol.t)
    assert np.max(np.abs(sol.q[:, 0] / xe - 1)) < 1e-9
    assert e.value.t == sol.t[-1] < 2.0


def test_t_eval_keeps_the_requested_times_reached(blow_up):
    q0, qd0 = start()
    times = np.linspace(0.0, 4.0, 41)
    with pytest.raises(lg.StepSizeError) as e:
        blow_up.simulate(q0, qd0, 5.0, method="dop853", rtol=1e-12, atol=1e-12, t_eval=times)
    err = e.value
    np.testing.assert_array_equal(err.solution.t, times[times <= err.t])
    assert abs(err.t - T_STAR) < 1e-12


def test_failures_before_the_run_carry_nothing(blow_up):
    with pytest.raises(ValueError) as e:
        blow_up.simulate([1.0, 2.0], [0.0], 1.0)
    assert not hasattr(e.value, "solution")
    # A fixed dt beyond the stability limit is refused before the first step.
    stiff = lg.scenes.damped_oscillator(1.0, 1e6, 0.0)
    with pytest.raises(lg.StiffnessError) as s:
        stiff.simulate([1.0], [0.0], 1.0, method="rk4", dt=0.01)
    err = s.value
    assert err.solution is None and err.t is None and err.q is None and err.qd is None


def test_y_is_scipy_layout():
    sol = lg.scenes.double_pendulum().simulate([1.0, 0.5], [0.0, 0.1], 1.0, rtol=1e-8)
    y = sol.y
    assert y.shape == (4, len(sol))
    np.testing.assert_array_equal(y, np.vstack([sol.q.T, sol.qd.T]))
    assert sol.y is y and not y.flags.writeable
