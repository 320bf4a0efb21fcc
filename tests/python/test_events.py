"""Events (``lg.Event``, ``simulate(..., events=[...])``) and the callable solution
(``dense=True``), against closed forms."""

import math

import numpy as np
import pytest

import lagrangian as lg

G = 9.81


def ellipk(m):
    """K(m) = π / (2 AGM(1, √(1 − m)))."""
    a, b = 1.0, math.sqrt(1.0 - m)
    for _ in range(60):
        a, b = 0.5 * (a + b), math.sqrt(a * b)
    return math.pi / (2.0 * a)


def pendulum(l=1.0):
    th, = lg.coordinates("th")
    return th, lg.Model(coordinates=[th], kinetic=0.5 * l**2 * th.d**2, potential=-G * l * lg.cos(th))


def projectile():
    x, y = lg.coordinates("x y")
    return (x, y), lg.Model(coordinates=[x, y], kinetic=0.5 * (x.d**2 + y.d**2), potential=G * y)


@pytest.mark.parametrize(
    "method, options",
    [("dop853", dict(rtol=1e-13, atol=1e-14)), ("radau5", dict(rtol=1e-13, atol=1e-14)),
     ("yoshida8", dict(dt=2e-3)), ("gauss6", dict(dt=2e-3))],
)
def test_pendulum_crossings_at_quarter_periods(method, options):
    # Released from rest at θ₀ = 2.5: θ falls through zero at T/4 + kT,
    # T = 4 √(l/g) K(sin²(θ₀/2)).
    theta0 = 2.5
    period = 4.0 * math.sqrt(1.0 / G) * ellipk(math.sin(theta0 / 2) ** 2)
    th, model = pendulum()
    down = lg.Event(th, direction=-1, name="down")
    sol = model.simulate([theta0], [0.0], 5.2 * period, method=method, events=[down], **options)
    assert sol.event_names == ("down",)
    t = sol.t_events[0]
    assert len(t) == 5
    exact = period / 4 + period * np.arange(5)
    tol = 1e-10 if method != "radau5" else 1e-9
    assert np.max(np.abs(t - exact)) < tol
    assert sol.q_events[0].shape == (5, 1)
    assert np.max(np.abs(sol.q_events[0])) < 1e-12
    assert np.all(sol.qd_events[0] < 0)
    assert sol.status == 0 and sol.message == "reached t_end"


@pytest.mark.parametrize("method, options", [("dop853", {}), ("stormer_verlet", dict(dt=0.01)),
                                             ("midpoint", dict(dt=0.01)), ("auto", {})])
def test_projectile_terminal_event(method, options):
    (x, y), model = projectile()
    v, alpha = 12.0, 0.7
    ground = lg.Event(y, direction=-1, terminal=True, name="ground")
    sol = model.simulate([0.0, 0.0], [v * math.cos(alpha), v * math.sin(alpha)], 100.0,
                         method=method, events=[ground], **options)
    flight = 2 * v * math.sin(alpha) / G
    assert sol.status == 1
    assert sol.message == f"terminal event ground at t = {float(sol.t[-1])!r}"
    assert sol.t[-1] == pytest.approx(flight, rel=1e-11)
    assert sol.t_events[0][0] == sol.t[-1]
    assert sol.q[-1, 0] == pytest.approx(v * v * math.sin(2 * alpha) / G, rel=1e-10)
    assert abs(sol.q[-1, 1]) < 1e-11


def test_bouncing_ball_ten_impacts():
    y, = lg.coordinates("y")
    g = lg.Parameter("g")
    ball = lg.Model(coordinates=[y], kinetic=0.5 * y.d**2, potential=g * y, parameters={"g": G})
    floor = lg.Event(y, direction=-1, reset={y.d: -0.8 * y.d}, name="floor")
    h = 2.0
    t1 = math.sqrt(2 * h / G)
    v1 = G * t1
    impacts = [t1]
    for j in range(1, 10):
        impacts.append(impacts[-1] + 2 * 0.8**j * v1 / G)
    t_end = impacts[-1] + 0.05
    sol = ball.simulate([h], [0.0], t_end, method="dop853", rtol=1e-12, atol=1e-12,
                        events=[floor])
    assert np.max(np.abs(sol.t_events[0] - impacts)) < 1e-9
    # The run went on through the impacts, the state jumping at each.
    assert sol.status == 0 and sol.t[-1] == t_end
    # h is a constant of the flight, not of a run whose resets take energy away; without the
    # reset, or with a terminal event only, it is one.
    assert sol.stats["conserved"] is False
    hit = lg.Event(y, direction=-1, terminal=True)
    assert ball.simulate([h], [0.0], t_end, events=[hit]).stats["conserved"] is True
    assert ball.simulate([h], [0.0], 0.1).stats["conserved"] is True
    damped = lg.Model(coordinates=[y], kinetic=0.5 * y.d**2, potential=g * y,
                      dissipation=0.1 * y.d**2, parameters={"g": G})
    assert damped.simulate([h], [0.0], 0.1).stats["conserved"] is False
    k = int(np.flatnonzero(sol.t == sol.t_events[0][0])[0])
    assert sol.t[k + 1] == sol.t[k] and sol.qd[k + 1, 0] == pytest.approx(-0.8 * sol.qd[k, 0])
    # A reset through a parameter of the model: e = 6 g / G = 1 on the moon, elastic bounces
    # at t₁ and 3 t₁.
    moon = ball.with_parameters(g=G / 6)
    elastic = lg.Event(y, direction=-1, reset={y.d: -y.d * 6 * g / G})
    sol = moon.simulate([h], [0.0], 5.0, rtol=1e-12, atol=1e-12, events=[elastic])
    t1 = math.sqrt(2 * h / (G / 6))
    np.testing.assert_allclose(sol.t_events[0], [t1, 3 * t1], atol=1e-9)


def test_henon_heiles_poincare_section():
    x, y = lg.coordinates("x y")
    model = lg.Model(coordinates=[x, y], kinetic=0.5 * (x.d**2 + y.d**2),
                     potential=0.5 * (x**2 + y**2) + x**2 * y - y**3 / 3)
    q0, qd0 = [0.0, 0.1], [0.35, 0.05]
    e0 = model.energy(0.0, q0, qd0)
    sol = model.simulate(q0, qd0, 500.0, rtol=1e-12, atol=1e-12,
                         events=[lg.Event(x, direction=+1)])
    q, qd = sol.q_events[0], sol.qd_events[0]
    assert len(q) > 50
    assert np.max(np.abs(q[:, 0])) <= 1e-12
    assert np.all(qd[:, 0] > 0)
    energies = [model.energy(t, a, b) for t, a, b in zip(sol.t_events[0], q, qd)]
    assert np.max(np.abs(np.array(energies) - e0)) < 1e-10


@pytest.mark.parametrize("method", ["rk4", "stormer_verlet", "gauss4", "midpoint"])
def test_two_crossings_inside_one_fixed_step(method):
    x, = lg.coordinates("x")
    free = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2)
    window = lg.Event((x - 0.3) * (x - 0.5))
    sol = free.simulate([0.0], [1.0], 1.0, method=method, dt=1.0, events=[window])
    assert sol.stats["accepted_steps"] == 1
    np.testing.assert_allclose(sol.t_events[0], [0.3, 0.5], atol=1e-14)


def test_conditions_in_time_velocity_and_parameters_on_both_backends():
    # x = sin t: ẋ = cos t falls through a = 0.5 at t = π/3 + 2kπ; t − 4 crosses once.
    x, = lg.coordinates("x")
    a = lg.Parameter("a")
    times = {}
    for backend in ("native", "interpreter"):
        spring = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=a * x**2,
                          parameters={"a": 0.5}, backend=backend)
        sol = spring.simulate([0.0], [1.0], 10.0, method="dop853", rtol=1e-12, atol=1e-12,
                              events=[lg.Event(x.d - a, direction=-1), lg.Event(lg.t - 4.0)])
        np.testing.assert_allclose(sol.t_events[0], [math.pi / 3, math.pi / 3 + 2 * math.pi],
                                   atol=1e-10)
        assert sol.t_events[1] == pytest.approx([4.0], abs=1e-13)
        times[backend] = sol.t_events
    # The machine code computes the conditions bit for bit as the interpreter does.
    for a_, b_ in zip(times["native"], times["interpreter"]):
        assert np.array_equal(a_, b_)


def test_terminal_count_and_t_eval():
    x, = lg.coordinates("x")
    spring = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * x**2)
    t_eval = np.linspace(0.0, 20.0, 201)
    sol = spring.simulate([0.0], [1.0], 20.0, rtol=1e-12, atol=1e-12, t_eval=t_eval,
                          events=[lg.Event(x, terminal=3)])
    assert sol.status == 1
    stop = 3 * math.pi
    np.testing.assert_allclose(sol.t_events[0], [math.pi, 2 * math.pi, stop], atol=1e-10)
    # Output times up to the stop only.
    assert np.array_equal(sol.t, t_eval[t_eval <= sol.t_events[0][-1]])
    np.testing.assert_allclose(sol.q[:, 0], np.sin(sol.t), atol=1e-10)


@pytest.mark.parametrize("method, options, tol, order",
                         [("dop853", dict(rtol=1e-12, atol=1e-12), 1e-10, 7),
                          ("dopri5", dict(rtol=1e-10, atol=1e-12), 1e-7, 4),
                          ("gauss6", dict(dt=0.01), 1e-10, 5)])
def test_dense_solution_is_callable(method, options, tol, order):
    x, = lg.coordinates("x")
    spring = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * x**2)
    sol = spring.simulate([0.0], [1.0], 10.0, method=method, dense=True, **options)
    kind, got_order = sol.interpolant
    assert got_order == order and isinstance(kind, str)
    t = np.linspace(0.0, 10.0, 1001)
    q, qd = sol(t)
    assert q.shape == (1001, 1) and qd.shape == (1001, 1)
    assert np.max(np.abs(q[:, 0] - np.sin(t))) < tol
    assert np.max(np.abs(qd[:, 0] - np.cos(t))) < 10 * tol
    q1, qd1 = sol(2.5)
    assert q1.shape == (1,) and q1[0] == pytest.approx(math.sin(2.5), abs=tol)
    with pytest.raises(ValueError, match="outside"):
        sol(10.5)
    with pytest.raises(ValueError):
        sol(float("nan"))
    # It pickles (and copies) with its interpolant.
    import copy
    import pickle

    for other in (pickle.loads(pickle.dumps(sol)), copy.deepcopy(sol)):
        assert np.array_equal(other(t)[0], q) and other.interpolant == sol.interpolant
    plain = spring.simulate([0.0], [1.0], 1.0)
    assert plain.interpolant is None
    with pytest.raises(ValueError, match="dense=True"):
        plain(0.5)


def test_failure_keeps_the_events_found():
    # ẍ = x² blows up at t* = √6 from x₀ = 1 with energy 0; x passes 2 and 4 before.
    x, = lg.coordinates("x")
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=-(x**3) / 3)
    with pytest.raises(lg.LagrangianError) as info:
        model.simulate([1.0], [math.sqrt(2 / 3)], 5.0, rtol=1e-10, atol=1e-10,
                       events=[lg.Event(x - 2.0), lg.Event(x - 4.0)])
    sol = info.value.solution
    assert sol.status == -1 and sol.message == str(info.value)
    a = math.sqrt(1 / 6)
    for k, level in enumerate([2.0, 4.0]):
        exact = (1 - math.sqrt(1 / level)) / a  # x = 1 / (1 − a t)²
        assert sol.t_events[k] == pytest.approx([exact], abs=1e-8)


def test_bad_events_are_rejected_before_the_run():
    x, = lg.coordinates("x")
    other, = lg.coordinates("z")
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2)
    with pytest.raises(ValueError, match="direction"):
        lg.Event(x, direction=2)
    with pytest.raises(ValueError, match="count"):
        lg.Event(x, terminal=0)
    with pytest.raises(TypeError, match="terminal"):
        lg.Event(x, terminal=1.5)
    with pytest.raises(ValueError, match="neither a coordinate nor a velocity"):
        lg.Event(x, reset={x + 1: 0.0})
    with pytest.raises(TypeError, match="expression"):
        lg.Event("x")
    with pytest.raises(TypeError, match="events=\\[event\\]"):
        model.simulate([0.0], [1.0], 1.0, events=lg.Event(x))
    with pytest.raises(ValueError, match="not a coordinate"):
        model.simulate([0.0], [1.0], 1.0, events=[lg.Event(other)])
    with pytest.raises(ValueError, match="no value"):
        model.simulate([0.0], [1.0], 1.0, events=[lg.Event(x - lg.Parameter("b"))])
    with pytest.raises(TypeError, match="dense"):
        model.simulate([0.0], [1.0], 1.0, dense="yes")
    # A condition that is not finite along the run is a typed error naming it.
    with pytest.raises(lg.NonFiniteError, match="event condition"):
        model.simulate([0.0], [1.0], 2.0, events=[lg.Event(lg.log(1.0 - x))])
    # The model still works.
    assert model.simulate([0.0], [1.0], 1.0).q[-1, 0] == pytest.approx(1.0)


def test_events_on_a_scene():
    pend = lg.scenes.simple_pendulum()
    th = pend.coordinates[0]
    sol = pend.simulate([0.5], [0.0], 3.0, rtol=1e-12, atol=1e-12,
                        events=[lg.Event(th, direction=-1, terminal=True)])
    g, l = pend.parameters["g"], pend.parameters["l"]
    quarter = math.sqrt(l / g) * ellipk(math.sin(0.25) ** 2)
    assert sol.t[-1] == pytest.approx(quarter, abs=1e-10)


def test_plot_of_a_dense_solution_draws_its_interpolant():
    pytest.importorskip("matplotlib")
    x, = lg.coordinates("x")
    spring = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * x**2)
    sol = spring.simulate([0.0], [1.0], 10.0, method="dop853", rtol=1e-10, atol=1e-12, dense=True)
    line = sol.plot().axes[0].lines[0]
    t, drawn = line.get_xdata(), line.get_ydata()
    assert len(t) > 5 * len(sol)
    assert np.array_equal(drawn, sol(t)[0][:, 0])
    assert np.max(np.abs(drawn - np.sin(t))) < 1e-8
