"""Evaluating a model at states: one state or k states as rows, through the fast path in Rust
(floats, float64 arrays, lists) or the checked path in Python (anything else), with the same
values either way and a clear ValueError for what cannot be a state."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import lagrangian as lg


@pytest.fixture(scope="module")
def dp():
    """The double pendulum (m = l = 1): M = [[2, c], [c, 1]] with c = cos(θ₁ − θ₂)."""
    th1, th2 = lg.coordinates("th1 th2")
    g, = lg.parameters("g")
    T = 0.5 * (2 * th1.d**2 + th2.d**2 + 2 * th1.d * th2.d * lg.cos(th1 - th2))
    U = -g * (2 * lg.cos(th1) + lg.cos(th2))
    return lg.Model(coordinates=[th1, th2], kinetic=T, potential=U, parameters={"g": 9.81})


def closed_form(q, qd, g=9.81):
    """q̈ of the double pendulum by hand (m = l = 1)."""
    d = q[0] - q[1]
    c, s = math.cos(d), math.sin(d)
    f1 = -qd[1] ** 2 * s - 2 * g * math.sin(q[0])
    f2 = qd[0] ** 2 * s - g * math.sin(q[1])
    det = 2 - c * c
    return np.array([(f1 - c * f2) / det, (2 * f2 - c * f1) / det])


STATES = np.random.default_rng(7).uniform(-2.0, 2.0, size=(6, 4))


def test_accelerations_match_the_closed_form_in_every_input_form(dp):
    for row in STATES:
        q, qd = row[:2], row[2:]
        want = closed_form(q, qd)
        for args in [(0.0, q, qd), (0, list(q), list(qd)), (0.0, tuple(q), tuple(qd)),
                     (np.float32(0.0), q, qd), (np.int64(0), q, qd),
                     (0.0, np.asfortranarray(np.stack([q, q]))[0], qd[::1])]:
            assert_allclose(dp.accelerations(*args), want, rtol=1e-13, atol=1e-13)


def test_batched_states_equal_one_call_per_row(dp):
    q, qd = STATES[:, :2], STATES[:, 2:]
    a = dp.accelerations(0.0, q, qd)
    assert a.shape == (6, 2)
    for k in range(6):
        assert_array_equal(a[k], dp.accelerations(0.0, q[k], qd[k]))
        assert_allclose(a[k], closed_form(q[k], qd[k]), rtol=1e-13, atol=1e-13)
    m = dp.mass_matrix(0.0, q, qd)
    assert m.shape == (6, 2, 2)
    c = np.cos(q[:, 0] - q[:, 1])
    assert_allclose(m[:, 0, 1], c, rtol=1e-15)
    assert_allclose(m[:, 1, 0], c, rtol=1e-15)
    assert_allclose(m[:, 0, 0], 2.0)
    p = dp.momenta(0.0, q, qd)
    assert_allclose(p, np.einsum("kij,kj->ki", m, qd), rtol=1e-14)
    e = dp.energy(0.0, q, qd)
    kinetic = 0.5 * np.einsum("ki,kij,kj->k", qd, m, qd)
    potential = -9.81 * (2 * np.cos(q[:, 0]) + np.cos(q[:, 1]))
    assert_allclose(e, kinetic + potential, rtol=1e-14)
    assert_allclose(dp.lagrangian(0.0, q, qd), kinetic - potential, rtol=1e-14)
    # Non-contiguous rows and lists of rows take the checked path, with the same values.
    assert_array_equal(dp.accelerations(0.0, STATES[:, 0:2], STATES[:, 2:4].tolist()), a)
    assert_array_equal(dp.accelerations(0.0, np.asfortranarray(q), qd), a)
    assert dp.accelerations(0.0, q[:0], qd[:0]).shape == (0, 2)


def test_one_state_gives_floats_and_vectors(dp):
    q, qd = STATES[0, :2], STATES[0, 2:]
    assert isinstance(dp.energy(0.0, q, qd), float)
    assert isinstance(dp.lagrangian(0.0, list(q), list(qd)), float)
    assert dp.mass_matrix(0.0, q, qd).shape == (2, 2)
    assert dp.momenta(0.0, q, qd).shape == (2,)


@pytest.mark.parametrize("t, q, qd, message", [
    (0.0, [1.0], [0.0, 0.0], r"q has shape \(1,\) but the model has 2 coordinates"),
    (0.0, [1.0, 2.0], [[0.0, 0.0]], r"q has shape \(2,\) but qd has shape \(1, 2\)"),
    (0.0, [[1.0, 2.0, 3.0]], [[0.0, 0.0, 0.0]], r"q has shape \(1, 3\) but needs \(2,\) or \(k, 2\)"),
    (0.0, [1.0, math.nan], [0.0, 0.0], r"q\[1\] = nan is not finite"),
    (0.0, [[1.0, 2.0], [0.0, math.inf]], np.zeros((2, 2)), r"q\[1, 1\] = inf is not finite"),
    (math.inf, [1.0, 2.0], [0.0, 0.0], "t = inf is not finite"),
    (0.0, "12", [0.0, 0.0], "q must be a sequence of 2 numbers, got a string"),
    (0.0, [1.0, 2.0], np.zeros((2, 2, 2)), r"qd has shape \(2, 2, 2\) but the model has 2"),
])
def test_bad_states_raise_value_error_with_what_to_give(dp, t, q, qd, message):
    for method in (dp.accelerations, dp.mass_matrix, dp.energy, dp.momenta, dp.lagrangian):
        with pytest.raises(ValueError, match=message):
            method(t, q, qd)


def test_time_must_be_a_real_number(dp):
    for t in (True, "0", None, 1j):
        with pytest.raises(TypeError, match="t must be a real number"):
            dp.accelerations(t, [1.0, 2.0], [0.0, 0.0])


def test_a_failing_state_in_a_batch_raises_and_returns_nothing():
    # M = diag(1, x²) is singular at x = 0: the second state of the batch fails.
    x, y = lg.coordinates("x y")
    model = lg.Model(coordinates=[x, y], kinetic=0.5 * (x.d**2 + x**2 * y.d**2),
                     potential=0.5 * x**2)
    q = np.array([[1.0, 0.0], [0.0, 0.0]])
    with pytest.raises(lg.SingularMassMatrixError):
        model.accelerations(0.0, q, np.zeros((2, 2)))
