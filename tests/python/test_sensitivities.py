"""Forward sensitivities (``simulate(..., sensitivities=[...])``, issue 42 items 1, 2 and 5)
against closed forms: the damped oscillator's derivatives in k, c, m and the initial state
(differentiated by sympy), Liouville's det ∂x(t)/∂x₀ = exp(−tr(M⁻¹C) t), the forced two masses
(seed eq. 41–44) differentiated by complex step, the time of an event by the implicit function
theorem; central differences on the chaotic double pendulum; and bad input."""

import cmath
import math
import pickle

import numpy as np
import pytest
import sympy as sp
from numpy.testing import assert_allclose

import lagrangian as lg

M0, K0, C0 = 1.3, 4.0, 0.3  # underdamped: c² < 4 m k
X0, V0 = 1.0, 0.5
T_END = 3.0


def damped(extra: bool = False, backend: str = "native") -> lg.Model:
    x, = lg.coordinates("x")
    m, k, c, z = lg.parameters("m k c z")
    params = {"m": M0, "k": K0, "c": C0}
    potential = 0.5 * k * x**2
    if extra:
        # A constant in the potential: the equations of motion do not depend on z.
        params["z"] = 7.0
        potential = potential + z**2
    return lg.Model(coordinates=[x], kinetic=0.5 * m * x.d**2, potential=potential,
                    dissipation=0.5 * c * x.d**2, parameters=params, backend=backend)


def damped_exact():
    """x(t), ẋ(t) of m ẍ + c ẋ + k x = 0 and their derivatives in (k, c, m, x0, v0), from
    x = e^{−γt}(x0 cos ωt + (v0 + γ x0)/ω sin ωt), γ = c/(2m), ω = √(k/m − γ²), differentiated
    by sympy: a function of t returning {name: (len(t), 2)} plus the state."""
    t, m, k, c, x0, v0 = sp.symbols("t m k c x0 v0", positive=True)
    g = c / (2 * m)
    w = sp.sqrt(k / m - g**2)
    x = sp.exp(-g * t) * (x0 * sp.cos(w * t) + (v0 + g * x0) / w * sp.sin(w * t))
    v = sp.diff(x, t)
    values = {m: M0, k: K0, c: C0, x0: X0, v0: V0}
    named = {"k": k, "c": c, "m": m, "q0": x0, "qd0": v0}
    out = {}
    for name, p in named.items():
        fx = sp.lambdify(t, sp.diff(x, p).subs(values), "numpy")
        fv = sp.lambdify(t, sp.diff(v, p).subs(values), "numpy")
        out[name] = (fx, fv)
    state = (sp.lambdify(t, x.subs(values), "numpy"), sp.lambdify(t, v.subs(values), "numpy"))

    def at(times):
        times = np.asarray(times, dtype=float)
        cols = {name: np.stack([np.broadcast_to(fx(times), times.shape),
                                np.broadcast_to(fv(times), times.shape)], axis=1)
                for name, (fx, fv) in out.items()}
        return cols, np.stack([state[0](times), state[1](times)], axis=1)

    return at


EXACT = damped_exact()
NAMES = ["k", "c", "m", "q0", "qd0"]

# (method, options, tolerance on every sensitivity at every output).
METHODS = [
    ("dop853", dict(rtol=1e-12, atol=1e-12), 1e-10),
    ("dopri5", dict(rtol=1e-12, atol=1e-12), 1e-10),
    ("radau5", dict(rtol=1e-12, atol=1e-12), 1e-10),
    ("taylor", dict(rtol=1e-12, atol=1e-12), 1e-10),
    ("gauss6", dict(dt=5e-3), 1e-10),
    ("gauss4", dict(dt=1e-3), 1e-10),
    ("rk4", dict(dt=1e-3), 1e-10),
    # The implicit midpoint rule is of order 2: its error is O(dt²) ≈ 1e-6 here.
    ("midpoint", dict(dt=1e-3), 1e-5),
]


def flat(sol, name):
    """The sensitivities of one direction as (len(t), 2) for this one-coordinate model."""
    s = sol.sensitivities[name]
    return s if s.ndim == 2 else s[:, :, 0]


@pytest.mark.parametrize("method, options, tol", METHODS, ids=[m[0] for m in METHODS])
def test_damped_oscillator_closed_form(method, options, tol):
    model = damped()
    sol = model.simulate([X0], [V0], T_END, method=method, sensitivities=NAMES, **options)
    assert sol.t[0] == 0.0 and sol.t[-1] == pytest.approx(T_END, abs=1e-12)
    assert set(sol.sensitivities) == set(NAMES)
    for name in ("k", "c", "m"):
        assert sol.sensitivities[name].shape == (len(sol.t), 2)
    for name in ("q0", "qd0"):
        assert sol.sensitivities[name].shape == (len(sol.t), 2, 1)
    exact, state = EXACT(sol.t)
    # The model's own run is the plain run's (q, q̇).
    assert_allclose(np.stack([sol.q[:, 0], sol.qd[:, 0]], axis=1), state, rtol=0, atol=tol)
    for name in NAMES:
        got = flat(sol, name)
        assert np.all(np.isfinite(got))
        err = np.max(np.abs(got - exact[name]))
        assert err <= tol, (method, name, err)
    # At t0 the sensitivities are their initial values: 0 for a parameter, the unit vector for
    # the initial state.
    assert np.array_equal(sol.sensitivities["k"][0], [0.0, 0.0])
    assert np.array_equal(sol.sensitivities["q0"][0], [[1.0], [0.0]])
    assert np.array_equal(sol.sensitivities["qd0"][0], [[0.0], [1.0]])


def test_sensitivities_do_not_change_the_run():
    # The model's coordinates are integrated with their sensitivities: at fixed dt with an
    # explicit method the state is the plain run's bit for bit (the sensitivities never feed
    # back into q).
    model = damped()
    plain = model.simulate([X0], [V0], T_END, method="rk4", dt=1e-2)
    sens = model.simulate([X0], [V0], T_END, method="rk4", dt=1e-2, sensitivities=["k"])
    assert np.array_equal(plain.t, sens.t)
    assert_allclose(sens.q, plain.q, rtol=0, atol=1e-15)
    assert_allclose(sens.qd, plain.qd, rtol=0, atol=1e-15)


@pytest.mark.parametrize("method, options", [("dop853", dict(rtol=1e-10, atol=1e-10)),
                                             ("taylor", dict(rtol=1e-10, atol=1e-10)),
                                             ("radau5", dict(rtol=1e-10, atol=1e-10)),
                                             ("gauss4", dict(dt=1e-2))])
def test_parameter_the_model_does_not_depend_on_gives_zeros(method, options):
    model = damped(extra=True)
    sol = model.simulate([X0], [V0], T_END, method=method, sensitivities=["z", "k"], **options)
    assert sol.sensitivities["z"].shape == (len(sol.t), 2)
    assert np.array_equal(sol.sensitivities["z"], np.zeros_like(sol.sensitivities["z"]))
    assert np.max(np.abs(sol.sensitivities["k"])) > 0.1


def test_parameter_of_an_event_only_gives_zeros():
    x, a, model = spring()
    sol = model.simulate([1.0], [0.0], 3.0, method="dop853", rtol=1e-10, atol=1e-10,
                         events=[lg.Event(x - a)], sensitivities=["a"])
    assert np.array_equal(sol.sensitivities["a"], np.zeros((len(sol.t), 2)))


def test_interpreter_backend_agrees():
    exact_sol = damped(backend="interpreter").simulate(
        [X0], [V0], T_END, method="dop853", rtol=1e-12, atol=1e-12, sensitivities=["k", "c"])
    exact, _ = EXACT(exact_sol.t)
    for name in ("k", "c"):
        assert np.max(np.abs(exact_sol.sensitivities[name] - exact[name])) < 1e-9


# Liouville: for M q̈ + C q̇ + ∇U(q) = 0 with constant M and C, the flow's divergence is
# −tr(M⁻¹C), so det ∂x(t)/∂x₀ = exp(−tr(M⁻¹C) t) whatever U is.
MASS = np.array([[2.0, 0.5], [0.5, 1.0]])
DAMP = np.array([[0.4, 0.1], [0.1, 0.3]])


def two_dof_damped() -> lg.Model:
    a, b = lg.coordinates("a b")
    qd = [a.d, b.d]
    kinetic = 0.5 * sum(MASS[i, j] * qd[i] * qd[j] for i in range(2) for j in range(2))
    dissipation = 0.5 * sum(DAMP[i, j] * qd[i] * qd[j] for i in range(2) for j in range(2))
    potential = 3.0 * a**2 + 2.0 * (b - a) ** 2 + 0.5 * a**4 + 0.3 * lg.cos(b)
    return lg.Model(coordinates=[a, b], kinetic=kinetic, potential=potential,
                    dissipation=dissipation)


def jacobian(sol, i):
    """∂(q, q̇)(t_i)/∂(q₀, q̇₀), 2n × 2n."""
    return np.concatenate([sol.sensitivities["q0"][i], sol.sensitivities["qd0"][i]], axis=1)


@pytest.mark.parametrize("method, options", [("dop853", dict(rtol=1e-12, atol=1e-12)),
                                             ("taylor", dict(rtol=1e-12, atol=1e-12)),
                                             ("radau5", dict(rtol=1e-12, atol=1e-12)),
                                             ("gauss6", dict(dt=5e-3))])
def test_liouville_determinant(method, options):
    model = two_dof_damped()
    rate = np.trace(np.linalg.solve(MASS, DAMP))
    sol = model.simulate([0.8, -0.4], [0.3, 1.1], 5.0, method=method,
                         sensitivities=["q0", "qd0"], **options)
    assert sol.sensitivities["q0"].shape == (len(sol.t), 4, 2)
    assert np.array_equal(jacobian(sol, 0), np.eye(4))
    for i in range(len(sol.t)):
        det = np.linalg.det(jacobian(sol, i))
        assert det == pytest.approx(math.exp(-rate * sol.t[i]), rel=1e-9), (i, sol.t[i])


def test_liouville_volume_preserved_without_damping():
    # C = 0: det = 1 (and the symplectic Gauss methods keep it to round-off).
    a, b = lg.coordinates("a b")
    model = lg.Model(coordinates=[a, b], kinetic=0.5 * (2 * a.d**2 + b.d**2 + a.d * b.d),
                     potential=3.0 * a**2 + 2.0 * (b - a) ** 2 + 0.5 * a**4)
    sol = model.simulate([0.8, -0.4], [0.3, 1.1], 5.0, method="gauss4", dt=1e-2,
                         sensitivities=["q0", "qd0"])
    dets = np.array([np.linalg.det(jacobian(sol, i)) for i in range(len(sol.t))])
    assert np.max(np.abs(dets - 1.0)) < 1e-11


# The double pendulum, chaotic from this state: central differences over t ≤ 2.
DP = {"m1": 1.0, "m2": 0.7, "l1": 1.1, "l2": 0.8, "g": 9.81}
DP_Q0, DP_QD0 = [2.0, -1.5], [0.3, 0.0]


def double_pendulum(**change) -> lg.Model:
    t1, t2 = lg.coordinates("t1 t2")
    m1, m2, l1, l2, g = lg.parameters("m1 m2 l1 l2 g")
    kinetic = (0.5 * (m1 + m2) * l1**2 * t1.d**2 + 0.5 * m2 * l2**2 * t2.d**2
               + m2 * l1 * l2 * t1.d * t2.d * lg.cos(t1 - t2))
    potential = -(m1 + m2) * g * l1 * lg.cos(t1) - m2 * g * l2 * lg.cos(t2)
    return lg.Model(coordinates=[t1, t2], kinetic=kinetic, potential=potential,
                    parameters={**DP, **change})


def state(sol):
    return np.concatenate([sol.q, sol.qd], axis=1)


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_double_pendulum_central_differences(method):
    t_eval = np.linspace(0.0, 2.0, 21)
    opts = dict(method=method, rtol=1e-13, atol=1e-13, t_eval=t_eval)
    sol = double_pendulum().simulate(DP_Q0, DP_QD0, 2.0, sensitivities=["l1", "g", "q0", "m2"],
                                     **opts)
    assert_allclose(sol.t, t_eval, rtol=0, atol=1e-14)
    # The motion is chaotic: the sensitivities grow by orders of magnitude over the span.
    assert np.max(np.abs(sol.sensitivities["q0"][-1])) > 10.0
    for name in ("l1", "g", "m2"):
        h = 1e-4 * DP[name]
        up = state(double_pendulum(**{name: DP[name] + h}).simulate(DP_Q0, DP_QD0, 2.0, **opts))
        down = state(double_pendulum(**{name: DP[name] - h}).simulate(DP_Q0, DP_QD0, 2.0, **opts))
        fd = (up - down) / (2 * h)
        got = sol.sensitivities[name]
        scale = np.max(np.abs(fd))
        assert np.max(np.abs(got - fd)) <= 1e-6 * scale, (name, np.max(np.abs(got - fd)), scale)
    model = double_pendulum()
    for j in range(2):
        h = 1e-5
        q_up, q_down = list(DP_Q0), list(DP_Q0)
        q_up[j] += h
        q_down[j] -= h
        fd = (state(model.simulate(q_up, DP_QD0, 2.0, **opts))
              - state(model.simulate(q_down, DP_QD0, 2.0, **opts))) / (2 * h)
        got = sol.sensitivities["q0"][:, :, j]
        scale = np.max(np.abs(fd))
        assert np.max(np.abs(got - fd)) <= 1e-6 * scale, (j, np.max(np.abs(got - fd)), scale)


# The forced two masses of seed eq. 41–44: M ẍ + K x = F cos Ωt, exact by Sylvester's formula
# for functions of the 2 × 2 matrix A = M⁻¹K, differentiated by complex step (exact to
# round-off: no subtraction).
TM = {"m1": 1.0, "m2": 0.5, "k1": 10.0, "k2": 5.0, "f1": 1.5, "f2": -0.7, "w": 2.3}
TM_Q0, TM_QD0 = np.array([0.2, -0.1]), np.array([0.0, 0.4])


def forced_two_mass() -> lg.Model:
    x1, x2 = lg.coordinates("x1 x2")
    m1, m2, k1, k2, f1, f2, w = lg.parameters("m1 m2 k1 k2 f1 f2 w")
    return lg.Model(coordinates=[x1, x2], kinetic=0.5 * m1 * x1.d**2 + 0.5 * m2 * x2.d**2,
                    potential=0.5 * k1 * x1**2 + 0.5 * k2 * (x2 - x1) ** 2,
                    forces=[f1 * lg.cos(w * lg.t), f2 * lg.cos(w * lg.t)], parameters=dict(TM))


def two_mass_exact(t, k1, k2, f2=TM["f2"], w=TM["w"]):
    """(x, ẋ) at t (complex k1, k2, f2, Ω allowed) from x = X cos Ωt + y, (K − Ω²M) X = F,
    and y = cos(√A t) y₀ + sin(√A t)/√A v₀, A = M⁻¹K."""
    m1, m2, f1 = (TM[s] for s in ("m1", "m2", "f1"))
    K = np.array([[k1 + k2, -k2], [-k2, k2]], dtype=complex)
    M = np.diag([m1, m2]).astype(complex)
    X = np.linalg.solve(K - w * w * M, np.array([f1, f2], dtype=complex))
    A = np.linalg.solve(M, K)
    tr, det = A[0, 0] + A[1, 1], A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    disc = cmath.sqrt(tr * tr - 4 * det)
    lam = [(tr - disc) / 2, (tr + disc) / 2]
    eye = np.eye(2)

    def f_of_a(f):
        return (f(lam[0]) * (A - lam[1] * eye) / (lam[0] - lam[1])
                + f(lam[1]) * (A - lam[0] * eye) / (lam[1] - lam[0]))

    y0, v0 = TM_Q0 - X, TM_QD0
    cos_a = f_of_a(lambda s: cmath.cos(cmath.sqrt(s) * t))
    sinc_a = f_of_a(lambda s: cmath.sin(cmath.sqrt(s) * t) / cmath.sqrt(s))
    msin_a = f_of_a(lambda s: -cmath.sqrt(s) * cmath.sin(cmath.sqrt(s) * t))
    x = X * cmath.cos(w * t) + cos_a @ y0 + sinc_a @ v0
    v = -w * X * cmath.sin(w * t) + msin_a @ y0 + cos_a @ v0
    return np.concatenate([x, v])


@pytest.mark.parametrize("method, options, tol", [
    ("dop853", dict(rtol=1e-12, atol=1e-12), 1e-9),
    ("taylor", dict(rtol=1e-12, atol=1e-12), 1e-9),
    ("radau5", dict(rtol=1e-12, atol=1e-12), 1e-9),
    ("gauss6", dict(dt=2e-3), 1e-9),
])
def test_forced_two_mass_closed_form(method, options, tol):
    t_eval = np.linspace(0.0, 4.0, 41)
    sol = forced_two_mass().simulate(TM_Q0, TM_QD0, 4.0, method=method, t_eval=t_eval,
                                     sensitivities=["k1", "k2", "w", "f2"], **options)
    h = 1e-30
    k1, k2 = TM["k1"], TM["k2"]
    for i, t in enumerate(sol.t):
        exact = two_mass_exact(t, k1, k2)
        assert np.max(np.abs(exact.imag)) == 0.0
        assert_allclose(state(sol)[i], exact.real, rtol=0, atol=tol)
        d1 = two_mass_exact(t, k1 + 1j * h, k2).imag / h
        d2 = two_mass_exact(t, k1, k2 + 1j * h).imag / h
        assert_allclose(sol.sensitivities["k1"][i], d1, rtol=0, atol=tol * max(1, np.max(abs(d1))))
        assert_allclose(sol.sensitivities["k2"][i], d2, rtol=0, atol=tol * max(1, np.max(abs(d2))))
        dw = two_mass_exact(t, k1, k2, w=TM["w"] + 1j * h).imag / h
        df = two_mass_exact(t, k1, k2, f2=TM["f2"] + 1j * h).imag / h
        assert_allclose(sol.sensitivities["w"][i], dw, rtol=0, atol=tol * max(1, np.max(abs(dw))))
        assert_allclose(sol.sensitivities["f2"][i], df, rtol=0, atol=tol)


def test_error_control_off_takes_fewer_steps():
    model = double_pendulum()
    opts = dict(rtol=1e-10, atol=1e-10, t_eval=np.linspace(0.0, 2.0, 11))
    for method in ("dop853", "dopri5", "radau5", "taylor"):
        on = model.simulate(DP_Q0, DP_QD0, 2.0, method=method, sensitivities=["g", "q0"], **opts)
        off = model.simulate(DP_Q0, DP_QD0, 2.0, method=method, sensitivities=["g", "q0"],
                             sensitivity_error_control=False, **opts)
        # Here the sensitivities, which grow along the chaotic motion, set the steps.
        assert off.stats["accepted_steps"] < on.stats["accepted_steps"], method
        for name in ("g", "q0"):
            a, b = on.sensitivities[name], off.sensitivities[name]
            assert np.all(np.isfinite(b))
            assert np.max(np.abs(a - b)) <= 1e-4 * np.max(np.abs(a)), (method, name)
    # On the damped oscillator, with the closed form: still accurate without error control.
    sol = damped().simulate([X0], [V0], T_END, method="dop853", rtol=1e-12, atol=1e-12,
                            sensitivities=["k", "c"], sensitivity_error_control=False)
    exact, _ = EXACT(sol.t)
    for name in ("k", "c"):
        assert np.max(np.abs(sol.sensitivities[name] - exact[name])) < 1e-8


def test_error_control_off_at_a_fixed_step_changes_nothing():
    model = damped()
    for method in ("rk4", "gauss4"):
        on = model.simulate([X0], [V0], 1.0, method=method, dt=1e-2, sensitivities=["k", "q0"])
        off = model.simulate([X0], [V0], 1.0, method=method, dt=1e-2, sensitivities=["k", "q0"],
                             sensitivity_error_control=False)
        assert np.array_equal(on.t, off.t)
        for name in ("k", "q0"):
            assert np.array_equal(on.sensitivities[name], off.sensitivities[name])


def test_error_control_off_with_taylor_takes_the_plain_runs_steps():
    # Taylor's step size from the norms of (q, q̇) alone: the steps of the run without
    # sensitivities (the same series of the model's own coordinates, to rounding: the
    # variational system solves with M's factors on the graph, the plain run with M₀'s).
    model = double_pendulum()
    plain = model.simulate(DP_Q0, DP_QD0, 2.0, method="taylor", rtol=1e-10, atol=1e-10)
    off = model.simulate(DP_Q0, DP_QD0, 2.0, method="taylor", rtol=1e-10, atol=1e-10,
                         sensitivities=["g"], sensitivity_error_control=False)
    assert off.stats["accepted_steps"] == plain.stats["accepted_steps"]
    np.testing.assert_allclose(off.t, plain.t, rtol=0, atol=1e-12)


def test_error_control_flag_type():
    with pytest.raises(TypeError):
        damped().simulate([X0], [V0], 1.0, sensitivities=["k"], sensitivity_error_control="no")


# Events: x″ = −k x from (x0, v0) crosses x = 0 first at t* = (π/2 + atan2(v0/ω, x0))/ω, ω = √k.
def spring(k=K0, a=0.3, order=("k", "a")):
    x, = lg.coordinates("x")
    kk, aa = lg.parameters("k a")
    # a enters the potential as a constant only (the equations of motion do not contain it)
    # and the events' conditions.
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * kk * x**2 + aa**2,
                     parameters={name: {"k": k, "a": a}[name] for name in order})
    return x, aa, model


def crossing_time():
    k, x0, v0 = sp.symbols("k x0 v0", positive=True)
    w = sp.sqrt(k)
    t_star = (sp.pi / 2 + sp.atan2(v0 / w, x0)) / w
    return {name: float(sp.diff(t_star, s).subs({k: K0, x0: X0, v0: V0}))
            for name, s in (("k", k), ("q0", x0), ("qd0", v0))}, float(
        t_star.subs({k: K0, x0: X0, v0: V0}))


@pytest.mark.parametrize("method, options", [("dop853", dict(rtol=1e-12, atol=1e-12)),
                                             ("taylor", dict(rtol=1e-12, atol=1e-12)),
                                             ("radau5", dict(rtol=1e-12, atol=1e-12)),
                                             ("gauss6", dict(dt=1e-3))])
def test_event_time_sensitivity(method, options):
    x, _, model = spring()
    dt_exact, t_star = crossing_time()
    zero = lg.Event(x, direction=-1, terminal=True, name="zero")
    sol = model.simulate([X0], [V0], 10.0, method=method, events=[zero],
                         sensitivities=["k", "q0", "qd0", "a"], **options)
    assert sol.t_events[0] == pytest.approx([t_star], abs=1e-10)
    assert sol.t[-1] == pytest.approx(t_star, abs=1e-10)
    assert len(sol.event_sensitivities) == 1
    ev = sol.event_sensitivities[0]
    assert ev["k"].shape == (1,) and ev["q0"].shape == (1, 1) and ev["qd0"].shape == (1, 1)
    assert ev["k"][0] == pytest.approx(dt_exact["k"], abs=1e-9)
    assert ev["q0"][0, 0] == pytest.approx(dt_exact["q0"], abs=1e-9)
    assert ev["qd0"][0, 0] == pytest.approx(dt_exact["qd0"], abs=1e-9)
    # The condition does not contain a: its time does not move with a.
    assert ev["a"][0] == 0.0


def test_event_time_from_rest_closed_form():
    # From x0 = 1 at rest: t* = π/(2√k), dt*/dk = −π/(4 k^{3/2}), dt*/dx0 = 0, dt*/dv0 = 1/k.
    x, _, model = spring()
    sol = model.simulate([1.0], [0.0], 10.0, method="dop853", rtol=1e-13, atol=1e-13,
                         events=[lg.Event(x, terminal=True)], sensitivities=["k", "q0", "qd0"])
    ev = sol.event_sensitivities[0]
    assert sol.t_events[0][0] == pytest.approx(math.pi / (2 * math.sqrt(K0)), abs=1e-12)
    assert ev["k"][0] == pytest.approx(-math.pi / (4 * K0**1.5), abs=1e-10)
    assert abs(ev["q0"][0, 0]) < 1e-10
    assert ev["qd0"][0, 0] == pytest.approx(1.0 / K0, abs=1e-10)


@pytest.mark.parametrize("order", [("k", "a"), ("a", "k")])
def test_event_time_sensitivity_in_a_parameter_of_the_condition(order):
    # x = cos ωt from rest at x0 = 1 reaches x = a at t* = acos(a)/ω:
    # dt*/da = −1/(ω √(1 − a²)), dt*/dk = −acos(a)/(2 k ω). The condition reads a alone, the
    # model both: whatever the order of the model's parameters, each derivative is its own.
    x, a, model = spring(order=order)
    assert tuple(model.parameters) == order
    w, av = math.sqrt(K0), 0.3
    sol = model.simulate([1.0], [0.0], 2.0, method="dop853", rtol=1e-13, atol=1e-13,
                         events=[lg.Event(x - a, direction=-1, name="down")],
                         sensitivities=["a", "k"])
    assert sol.t_events[0][0] == pytest.approx(math.acos(av) / w, abs=1e-12)
    ev = sol.event_sensitivities[0]
    assert ev["a"].shape == (1,)
    assert ev["a"][0] == pytest.approx(-1.0 / (w * math.sqrt(1 - av * av)), rel=1e-9)
    assert ev["k"][0] == pytest.approx(-math.acos(av) / (2 * K0 * w), rel=1e-9)


def test_event_sensitivities_at_every_occurrence():
    # Non-terminal: x = cos ωt crosses zero at t_j = (π/2 + jπ)/ω, dt_j/dk = −t_j/(2k).
    x, _, model = spring()
    sol = model.simulate([1.0], [0.0], 6.0, method="dop853", rtol=1e-13, atol=1e-13,
                         events=[lg.Event(x), lg.Event(lg.t - 1.0)], sensitivities=["k"])
    w = math.sqrt(K0)
    times = (math.pi / 2 + math.pi * np.arange(len(sol.t_events[0]))) / w
    assert len(times) == 4
    assert_allclose(sol.t_events[0], times, rtol=0, atol=1e-11)
    assert_allclose(sol.event_sensitivities[0]["k"], -times / (2 * K0), rtol=0, atol=1e-9)
    # An event on time alone does not move.
    assert_allclose(sol.event_sensitivities[1]["k"], [0.0], atol=0)


def test_event_with_reset_refused():
    x, _, model = spring()
    bounce = lg.Event(x, direction=-1, reset={x.d: -x.d})
    with pytest.raises(ValueError, match="reset"):
        model.simulate([1.0], [0.0], 3.0, events=[bounce], sensitivities=["k"])


def test_no_events_gives_empty_event_sensitivities():
    sol = damped().simulate([X0], [V0], 1.0, method="dop853", sensitivities=["k"])
    assert sol.event_sensitivities == []


# Outputs: t_eval, output_every, dense, pickle.
def test_t_eval_and_output_every():
    model = damped()
    t_eval = np.linspace(0.0, T_END, 17)
    sol = model.simulate([X0], [V0], T_END, method="dop853", rtol=1e-12, atol=1e-12,
                         t_eval=t_eval, sensitivities=["k", "qd0"])
    assert_allclose(sol.t, t_eval, rtol=0, atol=1e-15)
    assert sol.sensitivities["k"].shape == (17, 2)
    assert sol.sensitivities["qd0"].shape == (17, 2, 1)
    exact, _ = EXACT(t_eval)
    assert np.max(np.abs(sol.sensitivities["k"] - exact["k"])) < 1e-9
    assert np.max(np.abs(sol.sensitivities["qd0"][:, :, 0] - exact["qd0"])) < 1e-9
    full = model.simulate([X0], [V0], T_END, method="rk4", dt=1e-2, sensitivities=["k"])
    every = model.simulate([X0], [V0], T_END, method="rk4", dt=1e-2, output_every=7,
                           sensitivities=["k"])
    assert len(every.t) < len(full.t)
    assert every.sensitivities["k"].shape == (len(every.t), 2)
    index = np.searchsorted(full.t, every.t)
    assert_allclose(full.t[index], every.t, rtol=0, atol=1e-13)
    assert_allclose(every.sensitivities["k"], full.sensitivities["k"][index], rtol=0, atol=1e-14)


def test_dense_solution_is_the_models():
    model = two_dof_damped()
    sol = model.simulate([0.8, -0.4], [0.3, 1.1], 2.0, method="dop853", rtol=1e-12,
                         atol=1e-12, dense=True, sensitivities=["q0"])
    q, qd = sol(np.array([0.5, 1.5]))
    assert q.shape == (2, 2) and qd.shape == (2, 2)
    plain = model.simulate([0.8, -0.4], [0.3, 1.1], 2.0, method="dop853", rtol=1e-12,
                           atol=1e-12, t_eval=[0.5, 1.5])
    assert_allclose(q, plain.q, rtol=0, atol=1e-9)
    assert_allclose(qd, plain.qd, rtol=0, atol=1e-9)
    q1, qd1 = sol(1.0)
    assert np.asarray(q1).size == 2 and np.asarray(qd1).size == 2


def test_pickle_keeps_sensitivities():
    x, _, model = spring()
    sol = model.simulate([X0], [V0], 3.0, method="dop853", events=[lg.Event(x)], dense=True,
                         sensitivities=["k", "q0"])
    back = pickle.loads(pickle.dumps(sol))
    assert set(back.sensitivities) == {"k", "q0"}
    for name in ("k", "q0"):
        assert np.array_equal(back.sensitivities[name], sol.sensitivities[name])
    assert len(back.event_sensitivities) == 1
    for name in ("k", "q0"):
        assert np.array_equal(back.event_sensitivities[0][name], sol.event_sensitivities[0][name])
    assert np.array_equal(back(1.3)[0], sol(1.3)[0])


# The explicit symplectic methods carry the sensitivities of a separable system (the
# variational system of T = ½|q̇|², U(q) is separable too), each to its order, and refuse a
# dissipative one in a typed error that names the methods that fit.
@pytest.mark.parametrize("method, tol", [("stormer_verlet", 1e-6), ("yoshida4", 1e-10),
                                         ("yoshida6", 1e-12), ("yoshida8", 1e-12),
                                         ("blanes_moan4", 1e-12)])
def test_explicit_symplectic_methods(method, tol):
    _, _, model = spring()
    w = math.sqrt(K0)
    sol = model.simulate([1.0], [0.0], 2.0, method=method, dt=1e-3, sensitivities=["k", "q0"])
    t = sol.t
    assert np.max(np.abs(sol.sensitivities["k"][:, 0] + t * np.sin(w * t) / (2 * w))) < tol
    assert np.max(np.abs(sol.sensitivities["k"][:, 1]
                         + (np.sin(w * t) / (2 * w) + t * np.cos(w * t) / 2))) < 10 * tol
    assert np.max(np.abs(sol.sensitivities["q0"][:, 0, 0] - np.cos(w * t))) < tol
    with pytest.raises(ValueError, match="dop853"):
        damped().simulate([X0], [V0], 1.0, method=method, dt=1e-3, sensitivities=["k"])


def test_auto_method_gives_sensitivities():
    sol = damped().simulate([X0], [V0], T_END, rtol=1e-12, atol=1e-12, sensitivities=["k"])
    exact, _ = EXACT(sol.t)
    assert np.max(np.abs(sol.sensitivities["k"] - exact["k"])) < 1e-9


# Scenes: the initial state only.
def test_scene_initial_state_sensitivities():
    scene = lg.scenes.damped_oscillator(m=1.0, k=4.0, c=0.4)
    t_eval = np.linspace(0.0, 3.0, 13)
    sol = scene.simulate([0.7], [-0.2], 3.0, method="dop853", rtol=1e-12, atol=1e-12,
                         t_eval=t_eval, sensitivities=["q0", "qd0"])
    # The motion is linear in the initial state: ∂x/∂x₀ is the motion from (1, 0).
    for i, t in enumerate(t_eval):
        for name, start in (("q0", ([1.0], [0.0])), ("qd0", ([0.0], [1.0]))):
            q, qd = scene.exact(t, *start)
            assert_allclose(sol.sensitivities[name][i, :, 0], [q[0], qd[0]], rtol=0, atol=1e-10)


def test_scene_double_pendulum_matches_the_model():
    # The Rust scene and the same system stated with lg.Model give the same ∂x/∂x₀ (the scene's
    # variational system is traced from its Rust energies).
    scene = lg.scenes.double_pendulum(**DP)
    opts = dict(method="dop853", rtol=1e-13, atol=1e-13, t_eval=np.linspace(0.0, 2.0, 11))
    a = scene.simulate(DP_Q0, DP_QD0, 2.0, sensitivities=["q0", "qd0"], **opts)
    b = double_pendulum().simulate(DP_Q0, DP_QD0, 2.0, sensitivities=["q0", "qd0"], **opts)
    for name in ("q0", "qd0"):
        scale = np.max(np.abs(b.sensitivities[name]))
        assert np.max(np.abs(a.sensitivities[name] - b.sensitivities[name])) < 1e-8 * scale


def test_scene_parameter_refused():
    scene = lg.scenes.damped_oscillator()
    with pytest.raises(ValueError, match="q0"):
        scene.simulate([1.0], [0.0], 1.0, sensitivities=["k"])


# Bad input.
def test_unknown_name_lists_the_parameters():
    with pytest.raises(ValueError) as err:
        damped().simulate([X0], [V0], 1.0, sensitivities=["k", "spring"])
    text = str(err.value)
    for name in ("spring", "'m'", "'k'", "'c'", "q0", "qd0"):
        assert name in text


@pytest.mark.parametrize("names, error", [
    (["k", "k"], ValueError),
    (["q0", "q0"], ValueError),
    ([], ValueError),
    ("k", TypeError),
    ([1], TypeError),
    ({"k": 1}, TypeError),
])
def test_bad_names(names, error):
    with pytest.raises(error):
        damped().simulate([X0], [V0], 1.0, sensitivities=names)


def test_tuple_of_names_accepted():
    sol = damped().simulate([X0], [V0], 1.0, sensitivities=("k", "q0"))
    assert set(sol.sensitivities) == {"k", "q0"}


def _pendulums():
    """The same pendulum in Cartesian coordinates under its rod x² + y² = l² and in its angle."""
    x, y = lg.coordinates("x y")
    m, g, ln = lg.parameters("m g l")
    values = {"m": 1.0, "g": 9.81, "l": 1.5}
    cart = lg.Model([x, y], kinetic=0.5 * m * (x.d**2 + y.d**2), potential=m * g * y,
                    constraints=[x**2 + y**2 - ln**2], parameters=values)
    th, = lg.coordinates("th")
    mini = lg.Model([th], kinetic=0.5 * m * ln**2 * th.d**2, potential=-m * g * ln * lg.cos(th),
                    parameters=values)
    return cart, mini


@pytest.mark.parametrize("method", ["dop853", "radau5", "taylor"])
def test_constrained_model_against_its_minimal_coordinates(method):
    # x = l sin θ on the rod: ∂x/∂g = l cos θ ∂θ/∂g from the pendulum in its angle. Along l the
    # initial state is projected onto the moved rod in the M metric (here radially, θ₀ kept,
    # the Cartesian velocity kept): ∂x/∂l = sin θ + l cos θ (∂θ/∂l − (θ̇₀/l) ∂θ/∂θ̇₀).
    cart, mini = _pendulums()
    th0, w0, l = 0.7, 0.3, 1.5
    q0 = [l * math.sin(th0), -l * math.cos(th0)]
    qd0 = [l * math.cos(th0) * w0, l * math.sin(th0) * w0]
    t = np.linspace(0.0, 3.0, 7)
    sc = cart.simulate(q0, qd0, 3.0, t_eval=t, rtol=1e-12, atol=1e-12, method=method,
                       sensitivities=["g", "l", "m"])
    sm = mini.simulate([th0], [w0], 3.0, t_eval=t, rtol=1e-12, atol=1e-12, method=method,
                       sensitivities=["g", "l", "qd0"])
    th = sm.q[:, 0]
    dx_g = l * np.cos(th) * sm.sensitivities["g"][:, 0]
    np.testing.assert_allclose(sc.sensitivities["g"][:, 0], dx_g, rtol=0, atol=1e-9)
    dth_l = sm.sensitivities["l"][:, 0] - (w0 / l) * sm.sensitivities["qd0"][:, 0, 0]
    dx_l = np.sin(th) + l * np.cos(th) * dth_l
    np.testing.assert_allclose(sc.sensitivities["l"][:, 0], dx_l, rtol=0, atol=1e-9)
    # The mass drops out of a pendulum's motion.
    assert np.abs(sc.sensitivities["m"]).max() < 1e-12
    # The run stays on the rod to the tolerance and reports its multipliers.
    assert np.abs(sc.q[:, 0] ** 2 + sc.q[:, 1] ** 2 - l**2).max() < 1e-9
    assert sc.multipliers.shape == (len(t), 1)


def test_constrained_initial_sensitivities_are_tangent():
    # Along q0 the initial sensitivities are projected onto the rod's tangent: G s = 0 and the
    # velocity level too, for every column.
    cart, _ = _pendulums()
    q0, qd0 = [1.5, 0.0], [0.0, 2.0]
    s = cart.simulate(q0, qd0, 0.5, rtol=1e-12, atol=1e-12, sensitivities=["q0", "qd0"])
    for name in ("q0", "qd0"):
        first = s.sensitivities[name][0]  # (2n, n): rows ∂x, ∂y, ∂ẋ, ∂ẏ
        sq, sv = first[:2], first[2:]
        np.testing.assert_allclose(np.array(q0) @ sq, 0.0, atol=1e-14)
        np.testing.assert_allclose(np.array(q0) @ sv + np.array(qd0) @ sq, 0.0, atol=1e-14)


@pytest.mark.parametrize("method", ["auto", "dop853", "radau5"])
def test_constrained_long_run_reports_its_residual(method):
    # Issue 49, defect 2: over a long run at the default tolerances the run with sensitivities is
    # projected as the plain one is (the sensitivities with the state), so the residual it
    # reports is the true one of the states it returns, at the plain run's level, and the
    # sensitivities still follow the pendulum in its angle (x = l sin θ, y = −l cos θ).
    cart, mini = _pendulums()
    th0, l, t_end = 1.0, 1.5, 100.0
    q0 = [l * math.sin(th0), -l * math.cos(th0)]
    plain = cart.simulate(q0, [0.0, 0.0], t_end, method=method)
    sc = cart.simulate(q0, [0.0, 0.0], t_end, method=method, sensitivities=["g", "l"])
    x, y = sc.q[:, 0], sc.q[:, 1]
    true = np.maximum(np.abs(x**2 + y**2 - l**2),
                      np.abs(2 * (x * sc.qd[:, 0] + y * sc.qd[:, 1])))
    reported = sc.stats["constraint_residual"]
    assert sc.stats["projections"] > 0
    np.testing.assert_allclose(reported, true[1:].max(), rtol=1e-6)
    assert 0.0 < reported <= 3.0 * plain.stats["constraint_residual"]
    sm = mini.simulate([th0], [0.0], t_end, t_eval=sc.t, method="dop853", rtol=1e-13,
                       atol=1e-13, sensitivities=["g", "l"])
    th = sm.q[:, 0]
    state = max(np.abs(x - l * np.sin(th)).max(), np.abs(y + l * np.cos(th)).max())
    dg, dl = sm.sensitivities["g"][:, 0], sm.sensitivities["l"][:, 0]
    want = {"g": (l * np.cos(th) * dg, l * np.sin(th) * dg),
            "l": (np.sin(th) + l * np.cos(th) * dl, -np.cos(th) + l * np.sin(th) * dl)}
    for name, (wx, wy) in want.items():
        got = sc.sensitivities[name]
        size = max(np.abs(wx).max(), np.abs(wy).max())
        error = max(np.abs(got[:, 0] - wx).max(), np.abs(got[:, 1] - wy).max())
        # As accurate, relative to their size, as the state is (both about 2e-5 here; unprojected,
        # the run drifted off the rod to 1e-3 and both to 1e-2).
        assert error / size <= 3 * state / l and error / size < 1e-4, (name, error, size, state)


def test_constrained_inconsistent_state_and_ensemble_refused():
    cart, _ = _pendulums()
    with pytest.raises(ValueError, match="constraint"):
        cart.simulate([1.0, 0.0], [0.0, 0.0], 1.0, sensitivities=["l"])
    with pytest.raises(ValueError, match="ensemble"):
        cart.simulate_many([1.5, 0.0], [0.0, 1.0], 1.0, parameters={"g": [9.0, 9.81]},
                           sensitivities=["g"])


@pytest.mark.parametrize("q0, qd0", [([math.nan], [0.0]), ([1.0], [math.inf]), ([1.0, 2.0], [0.0])])
def test_bad_initial_state(q0, qd0):
    with pytest.raises(ValueError):
        damped().simulate(q0, qd0, 1.0, sensitivities=["k"])


def test_failure_keeps_finite_partial_results():
    # A step budget too small: a typed error, and what was computed has no NaN.
    with pytest.raises(lg.LagrangianError) as err:
        double_pendulum().simulate(DP_Q0, DP_QD0, 2.0, method="dop853", rtol=1e-12,
                                   atol=1e-12, max_steps=5, sensitivities=["g"])
    assert isinstance(err.value, lg.TooManyStepsError)
    # The partial run is the model's: its two coordinates, not the variational system's.
    part = err.value.solution
    assert part.q.shape == (len(part.t), 2) and part.qd.shape == (len(part.t), 2)
    assert np.all(np.isfinite(part.q)) and np.all(np.isfinite(part.qd))
    assert len(err.value.q) == 2 and len(err.value.qd) == 2
    assert err.value.t == part.t[-1]


# More of the same physics from other directions: backwards in time, from t0 ≠ 0, a model
# stated by its particles, events in the velocity and in time.
def test_backwards_and_from_a_later_start():
    model = damped()
    back = model.simulate([X0], [V0], -2.0, method="dop853", rtol=1e-12, atol=1e-12,
                          sensitivities=["k", "c", "qd0"])
    assert back.t[-1] == pytest.approx(-2.0, abs=1e-12)
    exact, _ = EXACT(back.t)
    for name in ("k", "c"):
        assert np.max(np.abs(back.sensitivities[name] - exact[name])) < 1e-9
    assert np.max(np.abs(back.sensitivities["qd0"][:, :, 0] - exact["qd0"])) < 1e-9
    # The system is autonomous: from t0 = 5 the sensitivities are those at t − t0.
    later = model.simulate([X0], [V0], 8.0, t0=5.0, method="taylor", rtol=1e-12, atol=1e-12,
                           sensitivities=["m", "q0"])
    exact, _ = EXACT(later.t - 5.0)
    assert np.max(np.abs(later.sensitivities["m"] - exact["m"])) < 1e-9
    assert np.max(np.abs(later.sensitivities["q0"][:, :, 0] - exact["q0"])) < 1e-9


def test_particle_model_central_differences():
    # A pendulum stated by its particle (position and mass): θ″ = −(g/l) sin θ, whose
    # sensitivities in l and in the mass (none: the mass cancels) against central differences.
    th, = lg.coordinates("th")
    mass, ln, g = lg.parameters("mass l g")
    values = {"mass": 0.7, "l": 1.3, "g": 9.81}
    model = lg.Model(coordinates=[th], positions=[(ln * lg.sin(th), -ln * lg.cos(th))],
                     masses=[mass], potential=-mass * g * ln * lg.cos(th), parameters=values)
    opts = dict(method="dop853", rtol=1e-13, atol=1e-13, t_eval=np.linspace(0.0, 3.0, 16))
    sol = model.simulate([2.0], [0.0], 3.0, sensitivities=["l", "mass"], **opts)
    assert np.max(np.abs(sol.sensitivities["mass"])) < 1e-12
    h = 1e-4
    up = state(model.with_parameters(l=1.3 + h).simulate([2.0], [0.0], 3.0, **opts))
    down = state(model.with_parameters(l=1.3 - h).simulate([2.0], [0.0], 3.0, **opts))
    fd = (up - down) / (2 * h)
    assert np.max(np.abs(sol.sensitivities["l"] - fd)) < 1e-6 * np.max(np.abs(fd))


def test_event_in_the_velocity():
    # x = cos ωt from rest: ẋ = −ω sin ωt rises through 0 at t* = π/ω, so dt*/dk = −π/(2kω);
    # the condition reads q̇, so ġ = ẍ enters the implicit function theorem.
    x, _, model = spring()
    w = math.sqrt(K0)
    sol = model.simulate([1.0], [0.0], 5.0, method="dop853", rtol=1e-13, atol=1e-13,
                         events=[lg.Event(x.d, direction=+1, terminal=True)],
                         sensitivities=["k", "qd0"])
    assert sol.t_events[0][0] == pytest.approx(math.pi / w, abs=1e-12)
    ev = sol.event_sensitivities[0]
    assert ev["k"][0] == pytest.approx(-math.pi / (2 * K0 * w), rel=1e-9)
    # From (1, v0): x = R cos(ωt − φ), φ = atan2(v0/ω, 1), turns at t* = (π + φ)/ω, so
    # dt*/dv0 = 1/ω² at v0 = 0.
    assert ev["qd0"][0, 0] == pytest.approx(1.0 / K0, rel=1e-9)


def test_event_on_a_forced_system_central_differences():
    # The forced two masses: the first time x₁ − x₂ = 0.05 + 0.02 t (the condition reads t,
    # so ∂g/∂t enters ġ), against central differences in k1 and Ω.
    x1, x2 = forced_two_mass().coordinates
    event = lg.Event(x1 - x2 - 0.05 - 0.02 * lg.t, terminal=True, name="meet")
    opts = dict(method="dop853", rtol=1e-13, atol=1e-13, events=[event])
    model = forced_two_mass()
    sol = model.simulate(TM_Q0, TM_QD0, 4.0, sensitivities=["k1", "w", "q0"], **opts)
    assert len(sol.t_events[0]) == 1
    ev = sol.event_sensitivities[0]
    for name, h in (("k1", 1e-5), ("w", 1e-6)):
        up = model.with_parameters(**{name: TM[name] + h}).simulate(TM_Q0, TM_QD0, 4.0, **opts)
        down = model.with_parameters(**{name: TM[name] - h}).simulate(TM_Q0, TM_QD0, 4.0, **opts)
        fd = (up.t_events[0][0] - down.t_events[0][0]) / (2 * h)
        assert ev[name][0] == pytest.approx(fd, rel=1e-6, abs=1e-8), name
    assert ev["q0"].shape == (1, 2)
    for j in range(2):
        h = 1e-6
        q_up, q_down = TM_Q0.copy(), TM_Q0.copy()
        q_up[j] += h
        q_down[j] -= h
        fd = (model.simulate(q_up, TM_QD0, 4.0, **opts).t_events[0][0]
              - model.simulate(q_down, TM_QD0, 4.0, **opts).t_events[0][0]) / (2 * h)
        assert ev["q0"][0, j] == pytest.approx(fd, rel=1e-6, abs=1e-8), j


def test_event_time_backwards():
    # Backwards from x0 = 1 at rest: x = cos ωt crosses zero at t* = −π/(2√k), so
    # dt*/dk = +π/(4 k^{3/2}); with ∂x/∂v0 = sin(ωt)/ω and ẋ(t*) = ω,
    # dt*/dv0 = −(sin(ωt*)/ω)/ω = 1/k.
    x, _, model = spring()
    sol = model.simulate([1.0], [0.0], -3.0, method="dop853", rtol=1e-13, atol=1e-13,
                         events=[lg.Event(x, terminal=True)], sensitivities=["k", "qd0"])
    w = math.sqrt(K0)
    t_star = -math.pi / (2 * w)
    assert sol.t_events[0][0] == pytest.approx(t_star, abs=1e-12)
    ev = sol.event_sensitivities[0]
    assert ev["k"][0] == pytest.approx(math.pi / (4 * K0**1.5), rel=1e-9)
    assert ev["qd0"][0, 0] == pytest.approx(1.0 / K0, rel=1e-9)


def test_velocity_dependent_forces_central_differences():
    # Van der Pol through generalized forces Q = μ (1 − x²) ẋ (not a Rayleigh function):
    # ∂/∂μ and ∂/∂(x₀, v₀) against central differences.
    x, = lg.coordinates("x")
    mu = lg.Parameter("mu")
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * x**2,
                     forces=[mu * (1 - x**2) * x.d], parameters={"mu": 1.5})
    opts = dict(method="dop853", rtol=1e-13, atol=1e-13, t_eval=np.linspace(0.0, 4.0, 9))
    sol = model.simulate([2.0], [0.0], 4.0, sensitivities=["mu", "q0", "qd0"], **opts)
    h = 1e-5
    up = state(model.with_parameters(mu=1.5 + h).simulate([2.0], [0.0], 4.0, **opts))
    down = state(model.with_parameters(mu=1.5 - h).simulate([2.0], [0.0], 4.0, **opts))
    fd = (up - down) / (2 * h)
    assert np.max(np.abs(sol.sensitivities["mu"] - fd)) < 1e-6 * np.max(np.abs(fd))
    for name, start in (("q0", ([2.0 + h], [0.0], [2.0 - h], [0.0])),
                        ("qd0", ([2.0], [h], [2.0], [-h]))):
        fd = (state(model.simulate(start[0], start[1], 4.0, **opts))
              - state(model.simulate(start[2], start[3], 4.0, **opts))) / (2 * h)
        got = sol.sensitivities[name][:, :, 0]
        assert np.max(np.abs(got - fd)) < 1e-6 * np.max(np.abs(fd)), name
