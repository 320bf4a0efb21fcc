"""``Model.rhs`` and ``Model.jacobian``: the model as a first-order system y = (q, q̇) in SciPy's
``fun(t, y)`` / ``jac(t, y)`` conventions, checked against ``accelerations``, against finite
differences, and by ``solve_ivp`` reaching the state ``Model.simulate`` reaches."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import lagrangian as lg


def python_double_pendulum():
    th1, th2 = lg.coordinates("th1 th2")
    m1, m2, l1, l2, g = lg.parameters("m1 m2 l1 l2 g")
    T = (0.5 * (m1 + m2) * l1**2 * th1.d**2 + 0.5 * m2 * l2**2 * th2.d**2
         + m2 * l1 * l2 * th1.d * th2.d * lg.cos(th1 - th2))
    U = -(m1 + m2) * g * l1 * lg.cos(th1) - m2 * g * l2 * lg.cos(th2)
    return lg.Model([th1, th2], kinetic=T, potential=U,
                    parameters=dict(m1=1.3, m2=0.7, l1=1.1, l2=0.8, g=9.81))


def forced_damped():
    """Time-dependent, dissipative and forced: every part of eq. 55 enters the Jacobian."""
    x, = lg.coordinates("x")
    return lg.Model([x], kinetic=0.5 * (1 + 0.1 * x**2) * x.d**2, potential=0.5 * 4.0 * x**2,
                    dissipation=0.5 * 0.3 * x.d**2, forces=[0.7 * lg.cos(1.3 * lg.t)])


MODELS = {
    "python_double_pendulum": python_double_pendulum,
    "scene_double_pendulum": lambda: lg.scenes.double_pendulum(1.3, 0.7, 1.1, 0.8, 9.81),
    "forced_damped": forced_damped,
    "n_pendulum": lambda: lg.scenes.n_pendulum([1.0, 0.5, 0.8], [1.2, 0.7, 0.9], 9.81),
}


def states(n, seed=7, count=5):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        yield rng.uniform(0.0, 3.0), rng.uniform(-1.5, 1.5, 2 * n)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_rhs_is_velocities_and_accelerations(name):
    model = MODELS[name]()
    n = model.dof
    for t, y in states(n):
        dy = model.rhs(t, y)
        assert dy.shape == (2 * n,) and dy.dtype == np.float64
        assert_array_equal(dy[:n], y[n:])
        assert_allclose(dy[n:], model.accelerations(t, y[:n], y[n:]), rtol=1e-14, atol=1e-14)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_rhs_vectorized_columns_are_states(name):
    # solve_ivp's vectorized=True passes y of shape (2n, k): one state per column.
    model = MODELS[name]()
    n = model.dof
    ys = np.array([y for _, y in states(n)]).T
    out = model.rhs(0.4, ys)
    assert out.shape == ys.shape
    for k in range(ys.shape[1]):
        assert_array_equal(out[:, k], model.rhs(0.4, ys[:, k]))
    # A strided (non-contiguous) view is read as it is.
    assert_array_equal(model.rhs(0.4, ys[:, ::2]), out[:, ::2])


@pytest.mark.parametrize("name", sorted(MODELS))
def test_jacobian_matches_finite_differences(name):
    model = MODELS[name]()
    n = model.dof
    for t, y in states(n, seed=11):
        jac = model.jacobian(t, y)
        assert jac.shape == (2 * n, 2 * n)
        assert_array_equal(jac[:n, :n], np.zeros((n, n)))
        assert_array_equal(jac[:n, n:], np.eye(n))
        # Central differences, error O(h²) ≈ 1e-10 relative at h = 1e-5.
        h = 1e-5
        fd = np.empty((2 * n, 2 * n))
        for j in range(2 * n):
            e = np.zeros(2 * n)
            e[j] = h
            fd[:, j] = (model.rhs(t, y + e) - model.rhs(t, y - e)) / (2 * h)
        assert_allclose(jac, fd, rtol=1e-7, atol=1e-7 * np.max(np.abs(fd)))


def test_rhs_and_jacobian_examples():
    osc = lg.scenes.damped_oscillator(m=2.0, k=8.0, c=0.4)
    assert_allclose(osc.rhs(0.0, [1.0, 0.5]), [0.5, -4.1], rtol=1e-15)
    assert_allclose(osc.jacobian(0.0, [1.0, 0.5]), [[0.0, 1.0], [-4.0, -0.2]], rtol=1e-15)


@pytest.mark.parametrize("bad", [np.zeros(3), np.zeros((4, 2, 1)), np.zeros((3, 2)), np.zeros(0)])
def test_rhs_rejects_wrong_shapes(bad):
    model = python_double_pendulum()
    with pytest.raises(ValueError, match=r"y has shape .* but needs \(4"):
        model.rhs(0.0, bad)


@pytest.mark.parametrize("bad", [np.zeros(3), np.zeros((4, 2)), np.zeros(5)])
def test_jacobian_rejects_wrong_shapes(bad):
    model = python_double_pendulum()
    with pytest.raises(ValueError, match=r"y has shape .* but needs \(4,\)"):
        model.jacobian(0.0, bad)


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_rhs_and_jacobian_reject_non_finite(bad):
    model = python_double_pendulum()
    y = np.array([0.1, 0.2, 0.3, bad])
    for f in (model.rhs, model.jacobian):
        with pytest.raises(ValueError, match=r"y\[3\] = .* is not finite"):
            f(0.0, y)
        with pytest.raises(ValueError, match="t = .* is not finite"):
            f(bad, np.zeros(4))
    with pytest.raises(ValueError, match=r"y\[3, 1\] = .* is not finite"):
        model.rhs(0.0, np.array([[0.0, 0.1], [0.0, 0.2], [0.0, 0.3], [0.0, bad]]))


def test_rhs_singular_mass_matrix_is_typed():
    ball = lg.scenes.ball_in_sphere(m=1.0, j=0.4, r1=1.0, r2=1.0, g=9.81)
    with pytest.raises(lg.SingularMassMatrixError):
        ball.rhs(0.0, [0.5, 0.0])
    with pytest.raises(lg.SingularMassMatrixError):
        ball.jacobian(0.0, [0.5, 0.0])


@pytest.mark.parametrize("method", ["RK45", "DOP853", "Radau", "LSODA", "BDF"])
def test_solve_ivp_on_rhs_reaches_simulate_final_state(method):
    integrate = pytest.importorskip("scipy.integrate")
    model = python_double_pendulum()
    q0, qd0, t_end = [1.0, 0.5], [0.0, 0.0], 3.0
    ours = model.simulate(q0, qd0, t_end, method="dop853", rtol=1e-12, atol=1e-12)
    kwargs = {} if method in ("RK45", "DOP853") else {"jac": model.jacobian}
    sol = integrate.solve_ivp(model.rhs, (0.0, t_end), q0 + qd0, method=method, rtol=1e-10,
                              atol=1e-10, **kwargs)
    assert sol.success, sol.message
    assert_allclose(sol.y[:2, -1], ours.q[-1], atol=1e-6)
    assert_allclose(sol.y[2:, -1], ours.qd[-1], atol=1e-6)
    if method in ("Radau", "BDF"):
        # (LSODA stays with its non-stiff Adams methods here and needs no Jacobian.)
        assert sol.njev >= 1


def test_solve_ivp_vectorized_and_events():
    integrate = pytest.importorskip("scipy.integrate")
    model = lg.scenes.double_pendulum(1.3, 0.7, 1.1, 0.8, 9.81)
    q0, qd0 = [1.0, 0.5], [0.0, 0.0]

    def crossing(t, y):
        return y[0]

    crossing.terminal = True  # type: ignore[attr-defined]
    sol = integrate.solve_ivp(model.rhs, (0.0, 5.0), q0 + qd0, method="Radau", rtol=1e-10,
                              atol=1e-10, vectorized=True, events=crossing)
    assert sol.status == 1 and sol.t_events[0].size == 1
    t_hit = float(sol.t_events[0][0])
    ours = model.simulate(q0, qd0, t_hit, method="dop853", rtol=1e-12, atol=1e-12)
    assert abs(ours.q[-1, 0]) < 1e-6
