"""The Taylor method and the Taylor coefficients of the motion (issue 16): coefficients against
closed forms for a velocity-dependent L (a charge in a magnetic field) and a time-dependent L (a
driven oscillator), the series summed against a tight DOP853 run on the double pendulum, the
energy of the double pendulum over 10⁴ periods, dense output, and the errors for what the method
cannot do."""

import math
import pickle
import re

import mpmath
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


class Series:
    """A truncated power series in t − t₀ over 50-digit mpmath numbers: the reference for the
    coefficients, by automatic differentiation of the explicit equations of motion (hand-derived
    q̈ = M⁻¹f, Cramer's rule): an implementation independent of ours in its equations, its
    arithmetic and its precision."""

    def __init__(self, c):
        self.c = list(c)

    @staticmethod
    def lift(x, n):
        return x if isinstance(x, Series) else Series([mpmath.mpf(x)] + [mpmath.mpf(0)] * (n - 1))

    def __add__(self, o):
        o = Series.lift(o, len(self.c))
        return Series([a + b for a, b in zip(self.c, o.c)])

    __radd__ = __add__

    def __neg__(self):
        return Series([-a for a in self.c])

    def __sub__(self, o):
        return self + (-Series.lift(o, len(self.c)))

    def __rsub__(self, o):
        return Series.lift(o, len(self.c)) - self

    def __mul__(self, o):
        if not isinstance(o, Series):
            return Series([a * o for a in self.c])
        n = len(self.c)
        return Series([mpmath.fsum(self.c[j] * o.c[k - j] for j in range(k + 1)) for k in range(n)])

    __rmul__ = __mul__

    def __truediv__(self, o):
        out = []
        for k in range(len(self.c)):
            out.append((self.c[k] - mpmath.fsum(o.c[j] * out[k - j] for j in range(1, k + 1)))
                       / o.c[0])
        return Series(out)

    def sincos(self):
        s, c = [mpmath.sin(self.c[0])], [mpmath.cos(self.c[0])]
        for k in range(1, len(self.c)):
            s.append(mpmath.fsum(j * self.c[j] * c[k - j] for j in range(1, k + 1)) / k)
            c.append(-mpmath.fsum(j * self.c[j] * s[k - j] for j in range(1, k + 1)) / k)
        return Series(s), Series(c)


def reference_coefficients(accelerations, t0, q0, qd0, order):
    """Coefficients 0..order of q and q̇ through (t0, q0, qd0) of q̈ = accelerations(t, q, q̇)
    (on Series), in 50 digits: coefficient k + 1 of q and q̇ from coefficient k of q̇ and q̈."""
    with mpmath.workdps(50):
        n, w = len(q0), order + 1
        q = [[mpmath.mpf(x)] + [mpmath.mpf(0)] * order for x in q0]
        v = [[mpmath.mpf(x)] + [mpmath.mpf(0)] * order for x in qd0]
        t = Series([mpmath.mpf(t0), mpmath.mpf(1)] + [mpmath.mpf(0)] * (order - 1))
        for k in range(order):
            acc = accelerations(t, [Series(c) for c in q], [Series(c) for c in v])
            for i in range(n):
                q[i][k + 1] = v[i][k] / (k + 1)
                v[i][k + 1] = acc[i].c[k] / (k + 1)
        return (np.array([[float(q[i][k]) for i in range(n)] for k in range(w)]),
                np.array([[float(v[i][k]) for i in range(n)] for k in range(w)]))


def assert_coefficients(model, accelerations, t0, q0, qd0, order=20, rtol=1e-12):
    cq, cqd = model.taylor_series(q0, qd0, t=t0, order=order)
    rq, rqd = reference_coefficients(accelerations, t0, q0, qd0, order)
    for k in range(order + 1):
        # Each order against its own size (the coefficients grow or decay like ρ⁻ᵏ).
        scale = max(np.abs(rq[k]).max(), np.abs(rqd[k]).max())
        worst = max(np.abs(cq[k] - rq[k]).max(), np.abs(cqd[k] - rqd[k]).max())
        assert worst <= rtol * scale, (k, worst, scale)


def test_coefficients_against_the_explicit_equations_in_50_digits():
    # The double pendulum, unequal links: M(q) couples the two accelerations.
    m1, m2, l1, l2, g = 1.0, 2.0, 1.5, 0.7, 9.81

    def double(t, q, v):
        (s1, _), (s2, _), (sd, cd) = q[0].sincos(), q[1].sincos(), (q[0] - q[1]).sincos()
        m11, m12, m22 = (m1 + m2) * l1**2, m2 * l1 * l2 * cd, m2 * l2**2
        f1 = -m2 * l1 * l2 * sd * v[1] * v[1] - (m1 + m2) * g * l1 * s1
        f2 = m2 * l1 * l2 * sd * v[0] * v[0] - m2 * g * l2 * s2
        det = m11 * m22 - m12 * m12
        return [(m22 * f1 - m12 * f2) / det, (m11 * f2 - m12 * f1) / det]

    assert_coefficients(double_pendulum(m1, m2, l1, l2, g), double, 0.0, [1.0, -0.5], [0.3, 2.0])

    # A pendulum on a pivot driven up and down, y_p = a cos ωt (time-dependent L):
    # l θ̈ = −(g + ÿ_p) sin θ.
    a, w, l = 0.1, 5.0, 1.0
    th, = lg.coordinates("th")
    pivot_speed = -a * w * lg.sin(w * lg.t)
    driven = lg.Model(coordinates=[th],
                      kinetic=0.5 * ((l * lg.cos(th) * th.d) ** 2
                                     + (pivot_speed + l * lg.sin(th) * th.d) ** 2),
                      potential=g * (a * lg.cos(w * lg.t) - l * lg.cos(th)))

    def pivot(t, q, v):
        _, cwt = (w * t).sincos()
        return [-(g - a * w**2 * cwt) * q[0].sincos()[0] * (1.0 / l)]

    assert_coefficients(driven, pivot, 0.7, [0.5], [-1.2])

    # A charge in a magnetic field and an anharmonic trap (velocity-dependent L):
    # ẍ = B ẏ − (k + λr²) x, ÿ = −B ẋ − (k + λr²) y.
    b, k, lam = 2.0, 1.0, 0.3
    x, y = lg.coordinates("x y")
    r2 = x**2 + y**2
    charge = lg.Model(coordinates=[x, y],
                      kinetic=0.5 * (x.d**2 + y.d**2) + 0.5 * b * (x * y.d - y * x.d),
                      potential=0.5 * k * r2 + 0.25 * lam * r2**2)

    def trap(t, q, v):
        spring = k + lam * (q[0] * q[0] + q[1] * q[1])
        return [b * v[1] - spring * q[0], -b * v[0] - spring * q[1]]

    assert_coefficients(charge, trap, 0.0, [1.0, -0.4], [0.2, 0.8])


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
    # A Rust scene expands its energies traced into the expression graph: the same series as
    # the same system stated as expressions.
    scene = lg.scenes.double_pendulum(m1=1.0, m2=2.0, l1=1.5, l2=0.7, g=9.81)
    cq, cqd = scene.taylor_series([1.0, 0.3], [0.2, -0.4], order=12)
    wq, wqd = model.taylor_series([1.0, 0.3], [0.2, -0.4], order=12)
    np.testing.assert_allclose(cq, wq, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(cqd, wqd, rtol=1e-12, atol=1e-14)


def test_energy_over_ten_thousand_periods():
    # Small oscillations (period ≈ 2π/ω of the slow mode): the energy stays at round-off, its
    # drift linear in time; the slope is printed (pytest -s) for docs/site/report.rst.
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


def chain(n: int) -> lg.Model:
    """N equal links, the bobs at running sums (as benches/taylor.py's N-pendulum)."""
    qs = lg.coordinates(" ".join(f"q{i}" for i in range(n)))
    y = vx = vy = T = U = 0.0
    for q in qs:
        y = y - lg.cos(q)
        vx, vy = vx + lg.cos(q) * q.d, vy + lg.sin(q) * q.d
        T = T + 0.5 * (vx**2 + vy**2)
        U = U + 9.81 * y
    return lg.Model(coordinates=list(qs), kinetic=T, potential=U)


def estimate(sol) -> float:
    return float(re.search(r"estimated at ([0-9.]+) times", sol.stats["choice"]).group(1))


def test_auto_picks_taylor_where_it_estimates_it_cheaper():
    # A charge in a magnetic field and a harmonic trap: a small smooth model, taylor's
    # expansion cheap. At tight tolerances auto runs taylor — the very run method="taylor"
    # gives — and the end state is the exact one to the tolerance; at the default ones DOP853.
    x, y = lg.coordinates("x y")
    qb, k = 2.0, 1.0
    charge = lg.Model(coordinates=[x, y], potential=0.5 * k * (x**2 + y**2),
                      kinetic=0.5 * (x.d**2 + y.d**2) + 0.5 * qb * (x * y.d - y * x.d))
    # z = x + iy obeys z̈ = −i qB ż − k z: z = Σ cⱼ e^(λⱼ t), λ² + i qB λ + k = 0.
    lam = [(-1j * qb + s * 1j * math.sqrt(qb**2 + 4 * k)) / 2 for s in (1, -1)]
    z0, v0, t_end = 1.0 + 0.0j, 0.5j, 50.0
    c1 = (v0 - lam[1] * z0) / (lam[0] - lam[1])
    c = [c1, z0 - c1]
    z = sum(cj * np.exp(lj * t_end) for cj, lj in zip(c, lam))
    zd = sum(cj * lj * np.exp(lj * t_end) for cj, lj in zip(c, lam))
    for tol in (1e-10, 1e-13):
        sol = charge.simulate([1.0, 0.0], [0.0, 0.5], t_end, rtol=tol, atol=tol)
        assert sol.stats["method"] == "taylor", sol.stats["choice"]
        assert estimate(sol) < 1.0 and "not stiff" in sol.stats["choice"]
        named = charge.simulate([1.0, 0.0], [0.0, 0.5], t_end, method="taylor", rtol=tol,
                                atol=tol)
        np.testing.assert_array_equal(sol.q, named.q)
        end = np.array([sol.q[-1, 0], sol.q[-1, 1], sol.qd[-1, 0], sol.qd[-1, 1]])
        exact = np.array([z.real, z.imag, zd.real, zd.imag])
        assert np.abs(end - exact).max() < 10 * tol * 50  # 50 time units of rounding
    loose = charge.simulate([1.0, 0.0], [0.0, 0.5], t_end)
    assert loose.stats["method"] == "dop853" and estimate(loose) > 1.0
    # The interpreter gets the same choice, and the same bits.
    slow = lg.Model(coordinates=[x, y], potential=0.5 * k * (x**2 + y**2),
                    kinetic=0.5 * (x.d**2 + y.d**2) + 0.5 * qb * (x * y.d - y * x.d),
                    backend="interpreter")
    again = slow.simulate([1.0, 0.0], [0.0, 0.5], t_end, rtol=1e-10, atol=1e-10)
    assert again.stats["method"] == "taylor"
    np.testing.assert_array_equal(again.q, charge.simulate([1.0, 0.0], [0.0, 0.5], t_end,
                                                           rtol=1e-10, atol=1e-10).q)


def test_auto_leaves_to_dop853_what_taylor_does_dearly_or_not_at_all():
    # The 4-link chain: the series of its M cost several DOP853 steps per Taylor step
    # (benches/taylor_choice.py: taylor 2–6 times slower at every tolerance).
    four = chain(4).simulate([0.3] * 4, [0.0] * 4, 2.0, rtol=1e-12, atol=1e-12)
    assert four.stats["method"] == "dop853" and estimate(four) > 1.5
    # A stiff spring: radau5, before any estimate.
    r, ph = lg.coordinates("r ph")
    stiff = lg.Model(coordinates=[r, ph], kinetic=0.5 * (r.d**2 + r**2 * ph.d**2),
                     potential=0.5e6 * (r - 1.0) ** 2 - 9.81 * r * lg.cos(ph),
                     dissipation=1e4 * r.d**2)
    sol = stiff.simulate([1.0, 0.5], [0.0, 0.0], 2.0, rtol=1e-12, atol=1e-12)
    assert sol.stats["method"] == "radau5"
    # A Rust scene: auto does not trace it (the trace would cost more than most runs), so it
    # chooses among the other methods as before.
    scene = lg.scenes.double_pendulum().simulate([1.0, 0.5], [0.0, 0.0], 1.0, rtol=1e-14,
                                                 atol=1e-14)
    assert scene.stats["method"] == "dop853" and "taylor" not in scene.stats["choice"]


def test_what_taylor_refuses():
    model = double_pendulum()
    x, = lg.coordinates("x")
    kinked = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=lg.abs(x))
    with pytest.raises(ValueError, match="no Taylor series"):
        kinked.simulate([1.0], [0.0], 1.0, method="taylor")
    tight = kinked.simulate([1.0], [0.0], 1.0, rtol=1e-14, atol=1e-14)
    assert tight.stats["method"] == "dop853" and "taylor" not in tight.stats["choice"]
    # A Rust scene is traced into the expression graph: taylor runs on it, and agrees with the
    # same system stated as expressions.
    scene = lg.scenes.double_pendulum(m1=1.0, m2=2.0, l1=1.5, l2=0.7, g=9.81)
    run = scene.simulate([1.0, 0.5], [0.0, 0.0], 1.0, method="taylor", rtol=1e-12, atol=1e-12)
    want = model.simulate([1.0, 0.5], [0.0, 0.0], 1.0, method="taylor", rtol=1e-12, atol=1e-12)
    assert run.stats["method"] == "taylor"
    np.testing.assert_allclose(run.q[-1], want.q[-1], rtol=0, atol=1e-10)
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
