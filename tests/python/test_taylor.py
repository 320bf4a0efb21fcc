"""The Taylor method and the Taylor coefficients of the motion (issue 16): coefficients against
closed forms for a velocity-dependent L (a charge in a magnetic field) and a time-dependent L (a
driven oscillator), the series summed against a tight DOP853 run on the double pendulum, the
energy of the double pendulum over 10⁴ periods, dense output, and the errors for what the method
cannot do."""

import math
import pickle

import numpy as np
import pytest

import lagrangian as lg


def double_pendulum(m1=1.0, m2=2.0, l1=1.5, l2=0.7, g=9.81) -> lg.Model:
    th1, th2 = lg.coordinates("th1 th2")
    T = (0.5 * (m1 + m2) * l1**2 * th1.d**2 + 0.5 * m2 * l2**2 * th2.d**2
         + m2 * l1 * l2 * th1.d * th2.d * lg.cos(th1 - th2))
    U = -(m1 + m2) * g * l1 * lg.cos(th1) - m2 * g * l2 * lg.cos(th2)
    return lg.Model(coordinates=[th1, th2], kinetic=T, potential=U)


def test_coefficients_of_a_charge_in_a_magnetic_field():
    # L = ½m|v|² + (qB/2)(x ẏ − y ẋ): a circle at ω = qB/m, ż = ż₀ e^(−iωt) with z = x + iy.
    m, qb = 1.3, 2.1
    x, y = lg.coordinates("x y")
    model = lg.Model(coordinates=[x, y],
                     kinetic=0.5 * m * (x.d**2 + y.d**2) + 0.5 * qb * (x * y.d - y * x.d))
    w = qb / m
    z0, v0 = 0.4 - 0.2j, 0.7 + 0.5j
    order = 20
    cq, cqd = model.taylor_series([z0.real, z0.imag], [v0.real, v0.imag], t=0.3, order=order)
    for k in range(order + 1):
        vk = v0 * (-1j * w) ** k / math.factorial(k)
        zk = z0 if k == 0 else v0 * (-1j * w) ** (k - 1) / math.factorial(k)
        assert abs(complex(*cqd[k]) - vk) <= 1e-15 * max(1.0, abs(vk)), k
        assert abs(complex(*cq[k]) - zk) <= 1e-15 * max(1.0, abs(zk)), k


def test_coefficients_of_a_driven_oscillator():
    # L = ½ẋ² − ½ω₀²x² + F x cos Ωt: x = A cos ω₀t + B sin ω₀t + C cos Ωt, C = F/(ω₀² − Ω²).
    w0, F, W, t0 = 1.7, 0.8, 0.6, 0.9
    x, = lg.coordinates("x")
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2,
                     potential=0.5 * w0**2 * x**2 - F * x * lg.cos(W * lg.t))
    C = F / (w0**2 - W**2)
    A, B = 0.3, -0.4  # chosen; the initial state at t0 follows

    def derivative(k):
        return (A * w0**k * math.cos(w0 * t0 + k * math.pi / 2)
                + B * w0**k * math.sin(w0 * t0 + k * math.pi / 2)
                + C * W**k * math.cos(W * t0 + k * math.pi / 2))

    order = 18
    cq, cqd = model.taylor_series([derivative(0)], [derivative(1)], t=t0, order=order)
    for k in range(order + 1):
        assert cq[k, 0] == pytest.approx(derivative(k) / math.factorial(k), rel=1e-13, abs=1e-16)
        assert cqd[k, 0] == pytest.approx(derivative(k + 1) / math.factorial(k),
                                          rel=1e-13, abs=1e-16)


def test_double_pendulum_series_sums_to_the_flow():
    model = double_pendulum()
    q0, qd0 = [1.0, -0.5], [0.3, 2.0]
    cq, cqd = model.taylor_series(q0, qd0, order=24)
    # Order 2 is half the acceleration from the compiled equations of motion.
    np.testing.assert_allclose(2 * cq[2], model.accelerations(0.0, q0, qd0), rtol=1e-14)
    for h in (0.05, -0.05, 0.1):
        sol = model.simulate(q0, qd0, h, method="dop853", rtol=1e-14, atol=1e-15)
        powers = h ** np.arange(25)
        np.testing.assert_allclose(powers @ cq, sol.q[-1], rtol=0, atol=2e-13)
        np.testing.assert_allclose(powers @ cqd, sol.qd[-1], rtol=0, atol=2e-12)


def test_taylor_series_rejects_what_it_cannot_expand():
    model = double_pendulum()
    with pytest.raises(ValueError, match="order"):
        model.taylor_series([1.0, 0.0], [0.0, 0.0], order=0)
    with pytest.raises(ValueError, match="order"):
        model.taylor_series([1.0, 0.0], [0.0, 0.0], order=101)
    with pytest.raises(ValueError, match="not finite"):
        model.taylor_series([math.nan, 0.0], [0.0, 0.0])
    with pytest.raises(ValueError, match="expressions"):
        lg.scenes.double_pendulum().taylor_series([1.0, 0.0], [0.0, 0.0])


def test_energy_over_ten_thousand_periods():
    # Small oscillations (period ≈ 2π/ω of the slow mode): the energy stays at round-off, its
    # drift linear in time; the slope is printed (pytest -s) for the README.
    model = double_pendulum()
    q0, qd0 = [0.1, 0.05], [0.0, 0.0]
    w = np.sqrt(np.linalg.eigvals(np.linalg.solve(
        model.mass_matrix(0.0, [0.0, 0.0], [0.0, 0.0]),
        model.linearize([0.0, 0.0]).K)).real.min())
    t_end = 1e4 * 2 * np.pi / w
    sol = model.simulate(q0, qd0, t_end, method="taylor", rtol=1e-15, atol=1e-15,
                         output_every=5000)
    h0 = sol.energy[0]
    rel = (sol.energy - h0) / abs(h0)
    slope = np.polyfit(sol.t, rel, 1)[0]
    print(f"energy over 1e4 periods ({sol.stats['accepted_steps']} steps): max "
          f"{np.abs(rel).max():.2e}, drift {slope:.2e} per unit time")
    assert np.abs(rel).max() < 1e-12
    assert abs(slope) * t_end < 1e-12


def test_what_taylor_refuses_and_auto_leaves_to_dop853():
    model = double_pendulum()
    tight = model.simulate([1.0, 0.5], [0.0, 0.0], 1.0, rtol=1e-12, atol=1e-12)
    assert tight.stats["method"] == "dop853"  # taylor is chosen by name only
    x, = lg.coordinates("x")
    kinked = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=lg.abs(x))
    with pytest.raises(ValueError, match="no Taylor series"):
        kinked.simulate([1.0], [0.0], 1.0, method="taylor")
    with pytest.raises(ValueError, match="expression"):
        lg.scenes.double_pendulum().simulate([1.0, 0.5], [0.0, 0.0], 1.0, method="taylor")
    with pytest.raises(ValueError, match="dt"):
        model.simulate([1.0, 0.5], [0.0, 0.0], 1.0, method="taylor", dt=0.01)


def test_dense_output_is_the_step_polynomial_and_pickles():
    x, = lg.coordinates("x")
    osc = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * x**2)
    sol = osc.simulate([1.0], [0.0], 20.0, method="taylor", rtol=1e-13, atol=1e-13, dense=True)
    assert "Taylor" in sol.interpolant[0] and sol.interpolant[1] >= 15
    t = np.linspace(0.0, 20.0, 997)
    q, qd = sol(t)
    np.testing.assert_allclose(q[:, 0], np.cos(t), atol=1e-12)
    np.testing.assert_allclose(qd[:, 0], -np.sin(t), atol=1e-12)
    again = pickle.loads(pickle.dumps(sol))
    np.testing.assert_array_equal(again(t)[0], q)
